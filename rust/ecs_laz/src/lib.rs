//! The LAZ codec of pcl_ecs: the `laz` crate (laz-rs, the LASzip implementation laspy uses through
//! lazrs) behind a C ABI of four functions. The C++ side (pcl_ecs/src/io/las_io.cpp) reads and
//! writes the LAS header, the VLRs and the point records; this library only turns raw LAS point
//! records into LASzip-compressed bytes and back.
//!
//! Every function returns 0 on success and a non-zero code with a message in `err` (NUL-terminated,
//! cut to `err_cap` bytes) on failure; a panic in the codec is caught and reported the same way, so
//! no input makes the caller's process abort.

use laz::{LasZipCompressor, LasZipDecompressor, LazItemRecordBuilder, LazVlr, LazVlrBuilder};
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
        let vlr = LazVlr::from_buffer(vlr).map_err(|e| format!("its LASzip VLR is invalid: {e}"))?;
        if vlr.items_size() != record_len as u64 {
            return Err(format!(
                "its LASzip VLR describes {}-byte records, the header {record_len}",
                vlr.items_size()
            ));
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
