//! The LAZ codec of pcl_ecs: the `laz` crate (laz-rs, the LASzip implementation laspy uses through
//! lazrs) behind a small C ABI: whole buffers (`ecs_laz_compress`, `ecs_laz_decompress`) and files
//! read or written a chunk at a time (`ecs_laz_reader_*`, `ecs_laz_writer_*`, for `--stream`). The C++ side (pcl_ecs/src/io/las_io.cpp) reads and
//! writes the LAS header, the VLRs and the point records; this library only turns raw LAS point
//! records into LASzip-compressed bytes and back.
//!
//! Every function returns 0 on success and a non-zero code with a message in `err` (NUL-terminated,
//! cut to `err_cap` bytes) on failure; a panic in the codec is caught and reported the same way, so
//! no input makes the caller's process abort.

use laz::laszip::ChunkTable;
use laz::{LasZipCompressor, LasZipDecompressor, LazItemRecordBuilder, LazItemType, LazVlr, LazVlrBuilder};
use std::ffi::CStr;
use std::fs::{File, OpenOptions};
use std::io::{BufReader, BufWriter, Cursor, Read, Seek, SeekFrom, Write};
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

/// The most extra bytes per record (LAS extra dimensions, after the point format's fields) that LAZ
/// is read or written with. The codec keeps arithmetic-coding models for every extra byte before it
/// reads or writes a point (measured: about 45 kB a byte for point formats 6-10, 7 kB for 0-5), so a
/// header that claims 63,000 extra bytes would cost 2 GB before the first point; 1,024 bytes (128
/// doubles) cost at most about 50 MB.
pub const MAX_EXTRA_BYTES: u64 = 1024;

/// `MAX_EXTRA_BYTES`, for the C++ side.
#[no_mangle]
pub extern "C" fn ecs_laz_max_extra_bytes() -> u64 {
    MAX_EXTRA_BYTES
}

/// Refuses, before the codec allocates for them, items that list one kind twice (LASzip lists each
/// of a point format's parts once; the codec keeps models for every item, so a forged list of
/// thousands of items would cost as much as as many extra bytes) or whose extra bytes pass
/// `MAX_EXTRA_BYTES`.
fn check_items(vlr: &LazVlr) -> Result<(), String> {
    let items = vlr.items();
    for (i, a) in items.iter().enumerate() {
        if items[..i]
            .iter()
            .any(|b| std::mem::discriminant(&b.item_type()) == std::mem::discriminant(&a.item_type()))
        {
            return Err(format!("its LASzip VLR lists the item {:?} twice", a.item_type()));
        }
    }
    let extra: u64 = vlr
        .items()
        .iter()
        .map(|i| match i.item_type() {
            LazItemType::Byte(n) | LazItemType::Byte14(n) => u64::from(n),
            _ => 0,
        })
        .sum();
    if extra > MAX_EXTRA_BYTES {
        return Err(format!(
            "its records carry {extra} extra bytes; LAZ is read and written with at most {MAX_EXTRA_BYTES} \
             (the codec keeps up to 45 kB of models per extra byte): use LAS (uncompressed) for these records"
        ));
    }
    Ok(())
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
        check_items(&vlr)?;
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
        check_items(&vlr)?;
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
        let len = file.len() as u64;
        let mut d = checked_decompressor(Bounded::new(Cursor::new(file), len), len, point_offset, vlr, count, record_len)?;
        // In steps, so that an error can say where the data ends.
        const STEP: usize = 50_000;
        let mut done = 0u64;
        for chunk in out.chunks_mut(STEP * record_len as usize) {
            decompress_step(&mut d, chunk, done, count)?;
            done += (chunk.len() / record_len as usize) as u64;
        }
        Ok(())
    })
}

/// A source of `len` bytes that refuses to seek past its end (the position stays where it was). A
/// file and bytes in memory differ there (a file refuses offsets above 2^63, bytes accept any), and
/// the codec goes on differently after a refused and an accepted seek to a damaged chunk table: with
/// this both readers (whole buffer and chunked) meet every file the same way.
struct Bounded<R> {
    inner: R,
    len: u64,
    pos: u64,
}

impl<R> Bounded<R> {
    fn new(inner: R, len: u64) -> Self {
        Bounded { inner, len, pos: 0 }
    }
}

impl<R: Read> Read for Bounded<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.pos += n as u64;
        Ok(n)
    }
}

impl<R: Seek> Seek for Bounded<R> {
    fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
        let target = match to {
            SeekFrom::Start(p) => i128::from(p),
            SeekFrom::End(d) => i128::from(self.len) + i128::from(d),
            SeekFrom::Current(d) => i128::from(self.pos) + i128::from(d),
        };
        if target < 0 || target > i128::from(self.len) {
            return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "a seek past the end of the data"));
        }
        self.pos = self.inner.seek(SeekFrom::Start(target as u64))?;
        Ok(self.pos)
    }
}

/// A decompressor for the `count` records of `record_len` bytes at `point_offset` of `src` (`len`
/// bytes), after the checks that keep a corrupt file from making the codec allocate what the file
/// cannot hold.
fn checked_decompressor<'a, R: Read + Seek + Send + Sync + 'a>(
    mut src: R,
    len: u64,
    point_offset: u64,
    vlr_bytes: &[u8],
    count: u64,
    record_len: u16,
) -> Result<LasZipDecompressor<'a, R>, String> {
    let vlr = LazVlr::from_buffer(vlr_bytes).map_err(|e| format!("its LASzip VLR is invalid: {e}"))?;
    if vlr.items_size() != record_len as u64 {
        return Err(format!(
            "its LASzip VLR describes {}-byte records, the header {record_len}",
            vlr.items_size()
        ));
    }
    check_items(&vlr)?;
    // The compressor (the payload's first u16): 1 point-wise (one stream, no chunk table), 2
    // point-wise chunked, 3 layered chunked.
    let compressor = if vlr_bytes.len() >= 2 { u16::from_le_bytes([vlr_bytes[0], vlr_bytes[1]]) } else { 0 };
    // The items of point formats 6-10 are compressed in layers, whose sizes the codec reads and
    // allocates before the points; LASzip writes them with the layered compressor alone, which is
    // the one whose layer sizes are checked below against the file.
    let layered = vlr.items().iter().any(|i| {
        matches!(
            i.item_type(),
            LazItemType::Point14 | LazItemType::RGB14 | LazItemType::RGBNIR14 | LazItemType::WavePacket14 | LazItemType::Byte14(_)
        )
    });
    if layered && compressor != 3 {
        return Err(format!(
            "its LASzip VLR lists the layered items of point formats 6-10 with compressor {compressor}, \
             not the layered one (3)"
        ));
    }
    if compressor != 1 {
        check_chunk_table(&mut src, len, point_offset, count, &vlr)?;
        // A chunked file's table must be readable: when it is not, the codec skips 8 bytes from
        // wherever the failed read left it (meant for sources that cannot seek) and decodes from
        // there, so what it reads depends on how the table was damaged.
        src.seek(SeekFrom::Start(point_offset)).map_err(|e| e.to_string())?;
        ChunkTable::read_from(&mut src, &vlr)
            .map_err(|e| format!("its compressed points are truncated or corrupt: their chunk table cannot be read ({e})"))?;
    }
    if compressor == 3 {
        check_layers(&mut src, len, point_offset, count, record_len, &vlr)?;
    }
    src.seek(SeekFrom::Start(point_offset)).map_err(|e| e.to_string())?;
    LasZipDecompressor::new(src, vlr).map_err(|e| format!("its compressed points are truncated or corrupt ({e})"))
}

fn decompress_step<'a, R: Read + Seek + Send + Sync + 'a>(
    d: &mut LasZipDecompressor<'a, R>,
    out: &mut [u8],
    done: u64,
    count: u64,
) -> Result<(), String> {
    d.decompress_many(out).map_err(|e| {
        format!("its compressed points are truncated or corrupt after about {done} of {count} points ({e})")
    })
}

/// `N` bytes at `at` of a source of `len` bytes, or None past its end.
fn bytes_at<R: Read + Seek, const N: usize>(src: &mut R, len: u64, at: u64) -> Option<[u8; N]> {
    if at.checked_add(N as u64)? > len {
        return None;
    }
    src.seek(SeekFrom::Start(at)).ok()?;
    let mut b = [0u8; N];
    src.read_exact(&mut b).ok()?;
    Some(b)
}

fn i64_at<R: Read + Seek>(src: &mut R, len: u64, at: u64) -> Option<i64> {
    bytes_at::<R, 8>(src, len, at).map(i64::from_le_bytes)
}

/// The chunk table's count of chunks, checked before the codec sizes its table by it: a file whose
/// table claims more chunks than its points can fill is corrupt (the codec would allocate 16 bytes
/// a claimed chunk first). The table is found as the codec finds it (the offset at the start of the
/// point data, else the last 8 bytes of the file).
fn check_chunk_table<R: Read + Seek>(
    src: &mut R,
    len: u64,
    point_offset: u64,
    count: u64,
    vlr: &LazVlr,
) -> Result<(), String> {
    let mut table = match i64_at(src, len, point_offset) {
        Some(t) => t,
        None => return Ok(()), // the codec says the data is missing
    };
    if table <= point_offset as i64 {
        table = match i64_at(src, len, len.saturating_sub(8)) {
            Some(t) => t,
            None => return Ok(()),
        };
        if table <= point_offset as i64 {
            return Ok(());
        }
    }
    let chunks = match i64_at(src, len, table as u64) {
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

fn u32_at<R: Read + Seek>(src: &mut R, len: u64, at: u64) -> Option<u32> {
    bytes_at::<R, 4>(src, len, at).map(u32::from_le_bytes)
}

/// The layer sizes of every chunk of a layered (LAS 1.4 point formats 6-10) LAZ, checked against
/// the chunk's bytes before the codec allocates a buffer of each size it reads (up to 4 GiB a
/// layer from a corrupt file). A chunk is its first point raw, its point count, one size per
/// layer, then the layers.
fn check_layers<R: Read + Seek>(
    src: &mut R,
    len: u64,
    point_offset: u64,
    count: u64,
    record_len: u16,
    vlr: &LazVlr,
) -> Result<(), String> {
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
    src.seek(SeekFrom::Start(point_offset)).map_err(|e| e.to_string())?;
    // The codec reads the chunks one after the other; the table (when there is one) says how many
    // bytes each may take.
    let table = Some(
        ChunkTable::read_from(&mut *src, vlr)
            .map_err(|e| format!("its compressed points are truncated or corrupt: their chunk table cannot be read ({e})"))?,
    );
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
            sum += u64::from(u32_at(src, len, sizes + 4 * l).ok_or_else(|| corrupt(k))?);
        }
        let end = sizes + 4 * layers + sum;
        if end > len {
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

/// A LAZ file's points read a chunk at a time (`ecs_laz_reader_*`): the file is opened here and
/// read as the points are asked for, so memory does not grow with the file.
pub struct EcsLazReader {
    d: LasZipDecompressor<'static, Bounded<BufReader<File>>>,
    count: u64,
    done: u64,
    record_len: u16,
}

unsafe fn path_of(path: *const c_char) -> Result<String, String> {
    if path.is_null() {
        return Err("no path".into());
    }
    CStr::from_ptr(path).to_str().map(str::to_owned).map_err(|_| "the path is not UTF-8".into())
}

/// Opens the `count` compressed records of `record_len` bytes at `point_offset` of the file at
/// `path` (NUL-terminated), described by the payload of its LASzip VLR. The same checks as
/// `ecs_laz_decompress` run first. On success `*reader` is set; free it with `ecs_laz_reader_close`.
#[no_mangle]
pub extern "C" fn ecs_laz_reader_open(
    path: *const c_char,
    point_offset: u64,
    vlr: *const u8,
    vlr_len: usize,
    count: u64,
    record_len: u16,
    reader: *mut *mut EcsLazReader,
    err: *mut c_char,
    err_cap: usize,
) -> c_int {
    run(err, err_cap, || {
        // SAFETY: the caller gives a NUL-terminated path and the length of its buffer.
        let (path, vlr) = unsafe { (path_of(path)?, slice(vlr, vlr_len)) };
        let file = File::open(&path).map_err(|e| format!("cannot open it ({e})"))?;
        let len = file.metadata().map_err(|e| e.to_string())?.len();
        let d = checked_decompressor(Bounded::new(BufReader::new(file), len), len, point_offset, vlr, count, record_len)?;
        let r = Box::new(EcsLazReader { d, count, done: 0, record_len });
        // SAFETY: `reader` is a valid pointer given by the caller.
        unsafe { *reader = Box::into_raw(r) };
        Ok(())
    })
}

/// Decompresses the next `n` records into `out` (`n * record_len` bytes). Asking past the count
/// the header declared is an error.
#[no_mangle]
pub extern "C" fn ecs_laz_reader_read(
    reader: *mut EcsLazReader,
    out: *mut u8,
    n: u64,
    err: *mut c_char,
    err_cap: usize,
) -> c_int {
    run(err, err_cap, || {
        // SAFETY: `reader` came from ecs_laz_reader_open and is not shared.
        let r = unsafe { reader.as_mut().ok_or("no reader")? };
        if n > r.count - r.done {
            return Err(format!("{n} points asked, {} left", r.count - r.done));
        }
        let total = usize::try_from(n)
            .ok()
            .and_then(|c| c.checked_mul(r.record_len as usize))
            .ok_or("too many points")?;
        // SAFETY: the caller gives `n * record_len` writable bytes.
        let out = if total == 0 { &mut [][..] } else { unsafe { std::slice::from_raw_parts_mut(out, total) } };
        decompress_step(&mut r.d, out, r.done, r.count)?;
        r.done += n;
        Ok(())
    })
}

/// Frees a reader (and closes its file).
#[no_mangle]
pub extern "C" fn ecs_laz_reader_close(reader: *mut EcsLazReader) {
    if !reader.is_null() {
        // SAFETY: made by Box::into_raw in ecs_laz_reader_open, freed once.
        drop(unsafe { Box::from_raw(reader) });
    }
}

/// LAZ points written a chunk at a time (`ecs_laz_writer_*`) after the header and VLRs that the
/// caller has already written to the file.
pub struct EcsLazWriter {
    c: LasZipCompressor<'static, BufWriter<File>>,
}

/// Opens the file at `path` (which holds the LAS header and VLRs, its length the offset of the
/// point data) to append records compressed with the LASzip VLR payload `vlr`.
#[no_mangle]
pub extern "C" fn ecs_laz_writer_open(
    path: *const c_char,
    vlr: *const u8,
    vlr_len: usize,
    writer: *mut *mut EcsLazWriter,
    err: *mut c_char,
    err_cap: usize,
) -> c_int {
    run(err, err_cap, || {
        // SAFETY: the caller gives a NUL-terminated path and the length of its buffer.
        let (path, vlr) = unsafe { (path_of(path)?, slice(vlr, vlr_len)) };
        let vlr = LazVlr::from_buffer(vlr).map_err(|e| e.to_string())?;
        check_items(&vlr)?;
        let mut file = OpenOptions::new().read(true).write(true).open(&path).map_err(|e| format!("cannot open it ({e})"))?;
        file.seek(SeekFrom::End(0)).map_err(|e| e.to_string())?;
        let c = LasZipCompressor::new(BufWriter::with_capacity(1 << 20, file), vlr).map_err(|e| e.to_string())?;
        let w = Box::new(EcsLazWriter { c });
        // SAFETY: `writer` is a valid pointer given by the caller.
        unsafe { *writer = Box::into_raw(w) };
        Ok(())
    })
}

/// Compresses `count` records of `record_len` bytes.
#[no_mangle]
pub extern "C" fn ecs_laz_writer_write(
    writer: *mut EcsLazWriter,
    records: *const u8,
    count: u64,
    record_len: u16,
    err: *mut c_char,
    err_cap: usize,
) -> c_int {
    run(err, err_cap, || {
        // SAFETY: `writer` came from ecs_laz_writer_open and is not shared.
        let w = unsafe { writer.as_mut().ok_or("no writer")? };
        if w.c.vlr().items_size() != record_len as u64 {
            return Err(format!("the LASzip items describe {}-byte records, not {record_len}", w.c.vlr().items_size()));
        }
        let total = usize::try_from(count)
            .ok()
            .and_then(|c| c.checked_mul(record_len as usize))
            .ok_or("too many points")?;
        // SAFETY: the caller gives the length of its buffer.
        let records = unsafe { slice(records, total) };
        w.c.compress_many(records).map_err(|e| format!("write error ({e})"))
    })
}

/// Ends the compressed data (the last chunk and the chunk table), flushes the file and frees the
/// writer. The file ends with the chunk table: the caller may append EVLRs after it.
#[no_mangle]
pub extern "C" fn ecs_laz_writer_finish(writer: *mut EcsLazWriter, err: *mut c_char, err_cap: usize) -> c_int {
    if writer.is_null() {
        return run(err, err_cap, || Err("no writer".into()));
    }
    // SAFETY: made by Box::into_raw in ecs_laz_writer_open, freed once (here).
    let mut w = unsafe { Box::from_raw(writer) };
    run(err, err_cap, move || {
        w.c.done().map_err(|e| format!("write error ({e})"))?;
        let mut out = w.c.into_inner();
        out.seek(SeekFrom::End(0)).map_err(|e| format!("write error ({e})"))?;
        out.flush().map_err(|e| format!("write error ({e})"))
    })
}

/// Frees a writer without finishing its file (after an error).
#[no_mangle]
pub extern "C" fn ecs_laz_writer_free(writer: *mut EcsLazWriter) {
    if !writer.is_null() {
        // SAFETY: made by Box::into_raw in ecs_laz_writer_open, freed once.
        drop(unsafe { Box::from_raw(writer) });
    }
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
