//! The LAZ codec of pcl_ecs: the `laz` crate (laz-rs, the LASzip implementation laspy uses through
//! lazrs) behind a C ABI of four functions. The C++ side (pcl_ecs/src/io/las_io.cpp) reads and
//! writes the LAS header, the VLRs and the point records; this library only turns raw LAS point
//! records into LASzip-compressed bytes and back.
//!
//! Every function returns 0 on success and a non-zero code with a message in `err` (NUL-terminated,
//! cut to `err_cap` bytes) on failure; a panic in the codec is caught and reported the same way, so
//! no input makes the caller's process abort.

use laz::laszip::ChunkTable;
use laz::{LasZipCompressor, LasZipDecompressor, LazItemRecordBuilder, LazItemType, LazVlr, LazVlrBuilder};
use std::io::{Cursor, Seek, SeekFrom};
use std::os::raw::{c_char, c_int};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Bytes allocated by this library; free them with `ecs_laz_free`.
#[repr(C)]
pub struct EcsLazBytes {
    pub data: *mut u8,
    pub len: usize,
    pub cap: usize,
}

fn give(out: *mut EcsLazBytes, mut v: Vec<u8>) {
    v.shrink_to_fit();
    let mut v = std::mem::ManuallyDrop::new(v);
    // SAFETY: `out` is a valid pointer given by the caller.
    unsafe {
        (*out).data = v.as_mut_ptr();
        (*out).len = v.len();
        (*out).cap = v.capacity();
    }
}

fn say(err: *mut c_char, err_cap: usize, msg: &str) {
    if err.is_null() || err_cap == 0 {
        return;
    }
    let bytes = msg.as_bytes();
    let n = bytes.len().min(err_cap - 1);
    // SAFETY: the caller gives `err_cap` writable bytes at `err`.
    unsafe {
        std::ptr::copy_nonoverlapping(bytes.as_ptr(), err as *mut u8, n);
        *err.add(n) = 0;
    }
}

fn run<F: FnOnce() -> Result<(), String>>(err: *mut c_char, err_cap: usize, f: F) -> c_int {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => 0,
        Ok(Err(msg)) => {
            say(err, err_cap, &msg);
            1
        }
        Err(_) => {
            say(err, err_cap, "the compressed data is corrupt (the LAZ codec stopped on it)");
            2
        }
    }
}

unsafe fn slice<'a>(p: *const u8, n: usize) -> &'a [u8] {
    if n == 0 {
        &[]
    } else {
        std::slice::from_raw_parts(p, n)
    }
}

/// The LASzip VLR payload (user id "laszip encoded", record id 22204) for LAS point format
/// `format` (0-10) with `extra_bytes` bytes after the standard fields, chunks of 50,000 points.
#[no_mangle]
pub extern "C" fn ecs_laz_vlr(
    format: u8,
    extra_bytes: u16,
    out: *mut EcsLazBytes,
    err: *mut c_char,
    err_cap: usize,
) -> c_int {
    run(err, err_cap, || {
        let items = LazItemRecordBuilder::default_for_point_format_id(format, extra_bytes)
            .map_err(|e| e.to_string())?;
        let vlr = LazVlrBuilder::new(items).build();
        let mut bytes = Vec::new();
        vlr.write_to(&mut bytes).map_err(|e| e.to_string())?;
        give(out, bytes);
        Ok(())
    })
}

/// Compresses `count` records of `record_len` bytes with the LASzip VLR payload `vlr`. The result
/// is `prefix` (the LAS header and VLRs, whose length is the offset of the point data) followed by
/// the compressed points and the chunk table, whose offset is written as LASzip places it.
#[no_mangle]
pub extern "C" fn ecs_laz_compress(
    prefix: *const u8,
    prefix_len: usize,
    vlr: *const u8,
    vlr_len: usize,
    records: *const u8,
    count: u64,
    record_len: u16,
    out: *mut EcsLazBytes,
    err: *mut c_char,
    err_cap: usize,
) -> c_int {
    run(err, err_cap, || {
        // SAFETY: the caller gives the lengths of its buffers.
        let (prefix, vlr, records) = unsafe {
            let total = usize::try_from(count)
                .ok()
                .and_then(|c| c.checked_mul(record_len as usize))
                .ok_or("too many points")?;
            (slice(prefix, prefix_len), slice(vlr, vlr_len), slice(records, total))
        };
        let vlr = LazVlr::from_buffer(vlr).map_err(|e| e.to_string())?;
        if vlr.items_size() != record_len as u64 {
            return Err(format!(
                "the LASzip items describe {}-byte records, not {record_len}",
                vlr.items_size()
            ));
        }
        let mut cursor = Cursor::new(prefix.to_vec());
        cursor.seek(SeekFrom::End(0)).map_err(|e| e.to_string())?;
        let mut compressor = LasZipCompressor::new(cursor, vlr).map_err(|e| e.to_string())?;
        compressor.compress_many(records).map_err(|e| e.to_string())?;
        compressor.done().map_err(|e| e.to_string())?;
        give(out, compressor.into_inner().into_inner());
        Ok(())
    })
}

/// Decompresses `count` records of `record_len` bytes into `out` (`count * record_len` bytes)
/// from a whole LAZ file held in memory (`file`), whose point data start at `point_offset`,
/// with the payload of its LASzip VLR. Corrupt or missing data is an error, never a short read.
#[no_mangle]
pub extern "C" fn ecs_laz_decompress(
    file: *const u8,
    file_len: usize,
    point_offset: u64,
    vlr: *const u8,
    vlr_len: usize,
    out: *mut u8,
    count: u64,
    record_len: u16,
    err: *mut c_char,
    err_cap: usize,
) -> c_int {
    run(err, err_cap, || {
        let total = usize::try_from(count)
            .ok()
            .and_then(|c| c.checked_mul(record_len as usize))
            .ok_or("too many points")?;
        // SAFETY: the caller gives the lengths of its buffers.
        let (file, vlr, out) = unsafe {
            (
                slice(file, file_len),
                slice(vlr, vlr_len),
                if total == 0 { &mut [][..] } else { std::slice::from_raw_parts_mut(out, total) },
            )
        };
        let vlr_bytes = vlr;
        let vlr = LazVlr::from_buffer(vlr).map_err(|e| format!("its LASzip VLR is invalid: {e}"))?;
        if vlr.items_size() != record_len as u64 {
            return Err(format!(
                "its LASzip VLR describes {}-byte records, the header {record_len}",
                vlr.items_size()
            ));
        }
        check_chunk_table(file, point_offset, count, &vlr)?;
        if vlr_bytes.len() >= 2 && u16::from_le_bytes([vlr_bytes[0], vlr_bytes[1]]) == 3 {
            check_layers(file, point_offset, count, record_len, &vlr)?;
        }
        let mut cursor = Cursor::new(file);
        cursor.seek(SeekFrom::Start(point_offset)).map_err(|e| e.to_string())?;
        let mut d = LasZipDecompressor::new(cursor, vlr).map_err(|e| format!("its compressed points are truncated or corrupt ({e})"))?;
        // In steps, so that an error can say where the data ends.
        const STEP: usize = 50_000;
        let mut done = 0usize;
        for chunk in out.chunks_mut(STEP * record_len as usize) {
            d.decompress_many(chunk).map_err(|e| {
                format!(
                    "its compressed points are truncated or corrupt after about {done} of {count} points ({e})"
                )
            })?;
            done += chunk.len() / record_len as usize;
        }
        Ok(())
    })
}

fn i64_at(file: &[u8], at: u64) -> Option<i64> {
    let at = usize::try_from(at).ok()?;
    let bytes = file.get(at..at.checked_add(8)?)?;
    Some(i64::from_le_bytes(bytes.try_into().ok()?))
}

/// The chunk table's count of chunks, checked before the codec sizes its table by it: a file whose
/// table claims more chunks than its points can fill is corrupt (the codec would allocate 16 bytes
/// a claimed chunk first). The table is found as the codec finds it (the offset at the start of the
/// point data, else the last 8 bytes of the file).
fn check_chunk_table(file: &[u8], point_offset: u64, count: u64, vlr: &LazVlr) -> Result<(), String> {
    let mut table = match i64_at(file, point_offset) {
        Some(t) => t,
        None => return Ok(()), // the codec says the data is missing
    };
    if table <= point_offset as i64 {
        table = match i64_at(file, (file.len() as u64).saturating_sub(8)) {
            Some(t) => t,
            None => return Ok(()),
        };
        if table <= point_offset as i64 {
            return Ok(());
        }
    }
    let chunks = match i64_at(file, table as u64) {
        Some(v) => (v as u64) >> 32, // version (u32), then the number of chunks (u32)
        None => return Ok(()),
    };
    let most = if vlr.uses_variable_size_chunks() {
        count + 1
    } else {
        count / u64::from(vlr.chunk_size().max(1)) + 2
    };
    if chunks > most {
        return Err(format!(
            "its compressed points are corrupt: the chunk table declares {chunks} chunks for {count} points"
        ));
    }
    Ok(())
}

fn u32_at(file: &[u8], at: u64) -> Option<u32> {
    let at = usize::try_from(at).ok()?;
    let bytes = file.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes(bytes.try_into().ok()?))
}

/// The layer sizes of every chunk of a layered (LAS 1.4 point formats 6-10) LAZ, checked against
/// the chunk's bytes before the codec allocates a buffer of each size it reads (up to 4 GiB a
/// layer from a corrupt file). A chunk is its first point raw, its point count, one size per
/// layer, then the layers.
fn check_layers(file: &[u8], point_offset: u64, count: u64, record_len: u16, vlr: &LazVlr) -> Result<(), String> {
    let layers: u64 = vlr
        .items()
        .iter()
        .map(|item| match item.item_type() {
            LazItemType::Point14 => 9,
            LazItemType::RGB14 | LazItemType::WavePacket14 => 1,
            LazItemType::RGBNIR14 => 2,
            LazItemType::Byte14(n) => u64::from(n),
            _ => 0,
        })
        .sum();
    let fixed = !vlr.uses_variable_size_chunks();
    let mut cursor = Cursor::new(file);
    cursor.seek(SeekFrom::Start(point_offset)).map_err(|e| e.to_string())?;
    // The codec reads the chunks one after the other; the table (when there is one) says how many
    // bytes each may take.
    let table = match ChunkTable::read_from(&mut cursor, vlr) {
        Ok(t) => Some(t),
        Err(_) if fixed => None,
        Err(e) => return Err(format!("its compressed points have no readable chunk table ({e})")),
    };
    let corrupt = |k: u64| format!("its compressed points are truncated or corrupt (chunk {k})");
    let mut pos = point_offset + 8;
    let mut left = count;
    let mut k = 0u64;
    while left > 0 {
        let entry = table.as_ref().and_then(|t| t.as_ref().get(k as usize));
        let in_chunk = if fixed {
            u64::from(vlr.chunk_size().max(1))
        } else {
            entry.map(|e| e.point_count).unwrap_or(left).max(1)
        };
        let sizes = pos + u64::from(record_len) + 4;
        let mut sum = 0u64;
        for l in 0..layers {
            sum += u64::from(u32_at(file, sizes + 4 * l).ok_or_else(|| corrupt(k))?);
        }
        let end = sizes + 4 * layers + sum;
        if end > file.len() as u64 {
            return Err(corrupt(k));
        }
        if let Some(e) = entry {
            if e.byte_count != 0 && end - pos > e.byte_count {
                return Err(corrupt(k));
            }
        }
        pos = end;
        left = left.saturating_sub(in_chunk);
        k += 1;
    }
    Ok(())
}

/// Frees bytes given by this library.
#[no_mangle]
pub extern "C" fn ecs_laz_free(bytes: *mut EcsLazBytes) {
    if bytes.is_null() {
        return;
    }
    // SAFETY: the bytes were made by `give` and are freed once.
    unsafe {
        if !(*bytes).data.is_null() {
            drop(Vec::from_raw_parts((*bytes).data, (*bytes).len, (*bytes).cap));
        }
        (*bytes).data = std::ptr::null_mut();
        (*bytes).len = 0;
        (*bytes).cap = 0;
    }
}
