//! Record file formats behind one trait.
//!
//! A format recognizes its files from their content ([`FileFormat::detect`]),
//! reads them into a [`RecordFile`] and encodes a [`RecordFile`] so that it
//! reads back unchanged. [`FORMATS`] lists the formats in the order they are
//! tried; [`parse_record`] picks the first whose `detect` accepts the bytes.
//! To add a format: implement [`FileFormat`] in a module of its own, add it
//! to [`FORMATS`] before the CSV fallback, and give it a [`Format`] variant
//! (see CONTRIBUTING.md).

use rayon::prelude::*;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use crate::csv;
use crate::error::{CampaignMismatch, IoOp, RecordError};
use crate::record::{Format, ReadOptions, RecordFile};
use crate::timeaxis;
use crate::uff::{self, Uff58Encoding};
use crate::write::write_atomically;

/// A record file format: detect, read, write.
pub trait FileFormat: Sync {
    /// Short name, as in messages (`csv`, `uff58`).
    fn name(&self) -> &'static str;

    /// Whether `bytes` are in this format, judged from the content only
    /// (never from the file name). Cheap: it looks at the first lines.
    fn detect(&self, bytes: &[u8]) -> bool;

    /// Parses a whole file; `path` is used in messages and stored.
    fn read(
        &self,
        bytes: &[u8],
        path: &Path,
        opts: &ReadOptions,
    ) -> Result<RecordFile, RecordError>;

    /// The bytes of `rec` in this format; refuses a record that would not
    /// read back unchanged (the error names `rec.path`).
    fn encode(&self, rec: &RecordFile) -> Result<Vec<u8>, RecordError>;

    /// Reads a whole file from `input`, with the same result as [`read`]
    /// on its content; [`read_record`] calls it once `detect` has accepted
    /// the file's start. The default reads the input into memory and calls
    /// [`read`]; a format that can parse as it reads (CSV) does so.
    ///
    /// [`read`]: FileFormat::read
    fn read_from(
        &self,
        input: &mut dyn BufRead,
        path: &Path,
        opts: &ReadOptions,
    ) -> Result<RecordFile, RecordError> {
        let mut bytes = Vec::new();
        input
            .read_to_end(&mut bytes)
            .map_err(|error| read_error(path, error))?;
        self.read(&bytes, path, opts)
    }
}

/// Delimited text (CSV): a header of channel names, optionally a time column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Csv;

/// Universal File Format dataset 58, written in the given encoding (both
/// encodings, and files mixing them, are read).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Uff58(pub Uff58Encoding);

/// The formats in detection order: UFF first (its files start with the
/// dataset delimiter `-1`), CSV last as the fallback for any text.
pub const FORMATS: [&dyn FileFormat; 2] = [&Uff58(Uff58Encoding::Ascii), &Csv];

impl FileFormat for Csv {
    fn name(&self) -> &'static str {
        "csv"
    }

    fn detect(&self, _bytes: &[u8]) -> bool {
        true
    }

    fn read(
        &self,
        bytes: &[u8],
        path: &Path,
        opts: &ReadOptions,
    ) -> Result<RecordFile, RecordError> {
        csv::parse_csv(bytes, path, opts)
    }

    fn read_from(
        &self,
        input: &mut dyn BufRead,
        path: &Path,
        opts: &ReadOptions,
    ) -> Result<RecordFile, RecordError> {
        csv::parse_csv_from(input, path, opts)
    }

    fn encode(&self, rec: &RecordFile) -> Result<Vec<u8>, RecordError> {
        csv_text(rec)
            .map(String::into_bytes)
            .map_err(|reason| refuse(&rec.path, reason))
    }
}

impl FileFormat for Uff58 {
    fn name(&self) -> &'static str {
        "uff58"
    }

    fn detect(&self, bytes: &[u8]) -> bool {
        let body = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        body.split(|&b| b == b'\n')
            .map(|l| l.trim_ascii())
            .find(|l| !l.is_empty())
            .is_some_and(|l| l == b"-1")
    }

    fn read(
        &self,
        bytes: &[u8],
        path: &Path,
        opts: &ReadOptions,
    ) -> Result<RecordFile, RecordError> {
        uff::parse_uff58(bytes, path, opts)
    }

    fn encode(&self, rec: &RecordFile) -> Result<Vec<u8>, RecordError> {
        if let Some(reason) = rec.consistency_problem() {
            return Err(refuse(&rec.path, reason));
        }
        uff::check_writable(rec).map_err(|reason| refuse(&rec.path, reason))?;
        Ok(uff::render_uff58(rec, self.0))
    }
}

impl Format {
    /// The format that writes records of this layout.
    pub fn file_format(self) -> &'static dyn FileFormat {
        match self {
            Format::Csv { .. } => &Csv,
            Format::Uff58Ascii => &Uff58(Uff58Encoding::Ascii),
            Format::Uff58Binary => &Uff58(Uff58Encoding::Binary),
        }
    }
}

/// The format of `bytes`: the first of [`FORMATS`] that detects them.
pub fn detect(bytes: &[u8]) -> &'static dyn FileFormat {
    FORMATS
        .into_iter()
        .find(|f| f.detect(bytes))
        .unwrap_or(&Csv)
}

/// Parses record content held in memory, recognising the format from the
/// content (see [`FORMATS`]). `path` is used in messages (and stored).
pub fn parse_record(
    bytes: &[u8],
    path: &Path,
    opts: &ReadOptions,
) -> Result<RecordFile, RecordError> {
    opts.validate()?;
    detect(bytes).read(bytes, path, opts)
}

/// Largest record file read, bytes. A record's samples are held as
/// doubles (and a UFF file is read whole): 2 GiB of text is about 100
/// million values (a 10^6-sample record of 100 channels), far beyond any
/// hammer or shaker record of a building model.
pub const MAX_FILE_BYTES: u64 = 2 << 30;

fn read_error(path: &Path, error: std::io::Error) -> RecordError {
    RecordError::Io {
        path: path.to_path_buf(),
        op: IoOp::Read,
        error,
    }
}

/// Refuses a file larger than [`MAX_FILE_BYTES`] before it is read.
fn check_size(path: &Path) -> Result<(), RecordError> {
    let len = std::fs::metadata(path)
        .map_err(|e| read_error(path, e))?
        .len();
    if len > MAX_FILE_BYTES {
        return Err(RecordError::TooLarge {
            path: path.to_path_buf(),
            bytes: len,
            limit: MAX_FILE_BYTES,
        });
    }
    Ok(())
}

/// Reads a whole file, refusing one larger than [`MAX_FILE_BYTES`] before
/// reading it.
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>, RecordError> {
    check_size(path)?;
    std::fs::read(path).map_err(|e| read_error(path, e))
}

/// Bytes read from the start of a file before the rest: enough for the
/// first line of any record file (format detection looks at the first
/// non-blank line).
const HEAD_BYTES: u64 = 64 * 1024;

/// The start of a file, and the reader positioned after it.
pub(crate) struct Head {
    /// The first bytes of the file (all of it if `complete`).
    pub bytes: Vec<u8>,
    /// The rest of the file.
    pub rest: BufReader<std::fs::File>,
    /// Whether `bytes` hold the whole file.
    pub complete: bool,
}

impl Head {
    /// Opens `path` (refusing a file larger than [`MAX_FILE_BYTES`]) and
    /// reads its first [`HEAD_BYTES`].
    pub(crate) fn read(path: &Path) -> Result<Self, RecordError> {
        check_size(path)?;
        let io = |e| read_error(path, e);
        let file = std::fs::File::open(path).map_err(io)?;
        let mut rest = BufReader::with_capacity(HEAD_BYTES as usize, file);
        let mut bytes = Vec::with_capacity(HEAD_BYTES as usize);
        (&mut rest)
            .take(HEAD_BYTES)
            .read_to_end(&mut bytes)
            .map_err(io)?;
        let complete = (bytes.len() as u64) < HEAD_BYTES;
        Ok(Self {
            bytes,
            rest,
            complete,
        })
    }

    /// Whether the first non-blank line (after a byte-order mark) is
    /// whole in `bytes`: then everything judged from it (the format, time
    /// record or FRF) is judged as from the whole file.
    pub(crate) fn first_line_whole(&self) -> bool {
        if self.complete {
            return true;
        }
        let body = self
            .bytes
            .strip_prefix(b"\xEF\xBB\xBF")
            .unwrap_or(&self.bytes);
        let mut segments = body.split(|&b| b == b'\n');
        // The last segment has no `\n` after it: it may go on in the file.
        let _ = segments.next_back();
        segments.any(|l| !l.trim_ascii().is_empty())
    }

    /// The whole file in memory.
    pub(crate) fn into_bytes(mut self, path: &Path) -> Result<Vec<u8>, RecordError> {
        if !self.complete {
            self.rest
                .read_to_end(&mut self.bytes)
                .map_err(|e| read_error(path, e))?;
        }
        Ok(self.bytes)
    }
}

/// Reads a record file of any known format. The format is recognised from
/// the file's first lines, then the file is read by the format's
/// [`FileFormat::read_from`]: CSV as it is parsed, without holding the
/// file's text in memory.
pub fn read_record(path: &Path, opts: &ReadOptions) -> Result<RecordFile, RecordError> {
    opts.validate()?;
    let head = Head::read(path)?;
    if !head.first_line_whole() {
        // A first line longer than the head (or a head of blank lines):
        // recognised from the whole content.
        let bytes = head.into_bytes(path)?;
        return parse_record(&bytes, path, opts);
    }
    let format = detect(&head.bytes);
    let mut input = std::io::Cursor::new(head.bytes).chain(head.rest);
    format.read_from(&mut input, path, opts)
}

/// Relative tolerance on the sampling interval of records of one campaign:
/// UFF stores the interval with 6 significant digits (E13.5), so the same
/// rate read from UFF and from a CSV time column can differ by 5e-6.
pub const CAMPAIGN_DT_REL_TOL: f64 = 1e-5;

/// Reads the records of one test campaign (several hits or runs) and checks
/// that they have the same sampling interval; the error names the first file
/// and the one that differs. Records may differ in length (runs of a shaker
/// test often do): everything downstream takes records of any lengths.
pub fn read_campaign<P: AsRef<Path> + Sync>(
    paths: &[P],
    opts: &ReadOptions,
) -> Result<Vec<RecordFile>, RecordError> {
    let records = read_records(paths, opts)?;
    check_campaign(&records)?;
    Ok(records)
}

/// Reads several record files ([`read_record`] each), in parallel. The records are in the
/// order of `paths`; when files fail, the error is the first failing file's in that order
/// (whatever the number of threads).
pub fn read_records<P: AsRef<Path> + Sync>(
    paths: &[P],
    opts: &ReadOptions,
) -> Result<Vec<RecordFile>, RecordError> {
    let each: Vec<Result<RecordFile, RecordError>> = paths
        .par_iter()
        .map(|p| read_record(p.as_ref(), opts))
        .collect();
    each.into_iter().collect()
}

/// Checks that records have the same sampling interval (within
/// [`CAMPAIGN_DT_REL_TOL`]), the first one being the reference. Their
/// lengths may differ.
pub fn check_campaign(records: &[RecordFile]) -> Result<(), RecordError> {
    let Some((first, rest)) = records.split_first() else {
        return Err(RecordError::EmptyCampaign);
    };
    for r in rest {
        let mismatch = if (r.dt_s - first.dt_s).abs() > CAMPAIGN_DT_REL_TOL * first.dt_s {
            Some(CampaignMismatch::SamplingInterval {
                reference_s: first.dt_s,
                other_s: r.dt_s,
            })
        } else {
            None
        };
        if let Some(mismatch) = mismatch {
            return Err(RecordError::Campaign {
                reference: first.path.clone(),
                other: r.path.clone(),
                mismatch,
            });
        }
    }
    Ok(())
}

fn refuse(path: &Path, reason: String) -> RecordError {
    RecordError::InvalidRecord {
        path: path.to_path_buf(),
        reason,
    }
}

/// Writes `rec` to `path` in `format`, atomically (see [`write_atomically`]).
pub fn write_record(
    path: &Path,
    rec: &RecordFile,
    format: &dyn FileFormat,
) -> Result<(), RecordError> {
    let bytes = format.encode(rec).map_err(|e| rename_refusal(e, path))?;
    write_atomically(path, &bytes)
}

/// A refusal to encode names the record's own path; when writing, name the
/// target instead.
fn rename_refusal(e: RecordError, path: &Path) -> RecordError {
    match e {
        RecordError::InvalidRecord { reason, .. } => refuse(path, reason),
        other => other,
    }
}

/// Writes `rec` as CSV: header `time,<name [unit]>...`, one row per sample,
/// time in seconds computed as `start_s + i * dt_s`, every number in the
/// shortest form that reads back bit for bit. Node, direction and ID line
/// are not stored. Refuses records that would not read back unchanged.
pub fn write_csv(path: &Path, rec: &RecordFile) -> Result<(), RecordError> {
    write_record(path, rec, &Csv)
}

/// Writes `rec` as UFF dataset 58 in the given encoding: binary (58b,
/// little-endian doubles, bit-exact) or ASCII as the format prescribes
/// (4E20.12, 13 significant digits). Each channel is a time response
/// (function type 1) at its node and direction (0 if unknown), ID line 1 is
/// the channel name, record 9 carries the unit. Record 7 holds start and
/// interval with 6 digits (E13.5) as prescribed; the exact values are added
/// to ID line 5 (`frameid dt_s=… start_s=…`) and used by [`read_record`]
/// when they agree with record 7.
pub fn write_uff58(path: &Path, rec: &RecordFile, enc: Uff58Encoding) -> Result<(), RecordError> {
    write_record(path, rec, &Uff58(enc))
}

fn csv_text(rec: &RecordFile) -> Result<String, String> {
    if let Some(reason) = rec.consistency_problem() {
        return Err(reason);
    }
    for (i, ch) in rec.channels.iter().enumerate() {
        if let Some(reason) = csv::header_round_trip_problem(ch, i) {
            return Err(reason);
        }
    }
    let n = rec.len();
    if n < 2 {
        return Err(
            "a single sample cannot carry its sampling interval in a CSV time column".into(),
        );
    }
    // The reader recovers dt from the time column; make sure it will get
    // it back (bit for bit in the usual cases, to 1e-9 always).
    let t: Vec<f64> = (0..n).map(|i| rec.time_s(i)).collect();
    match timeaxis::check_uniform(&t, &timeaxis::PrintModel::exact(), 1.0) {
        Ok(dt) if (dt - rec.dt_s).abs() <= 1e-9 * rec.dt_s => Ok(csv::render_csv(rec)),
        Ok(dt) => Err(format!(
            "with start_s = {} s the time column cannot carry dt_s = {} s (it would read back as {dt} s); use UFF",
            rec.start_s, rec.dt_s
        )),
        Err(_) => Err(format!(
            "the time stamps start_s + i*dt_s (start {} s, dt {} s) are not uniform at double precision",
            rec.start_s, rec.dt_s
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frf::{ContentKind, content_kind, read_content_kind};
    use crate::record::Channel;

    fn record(n: usize) -> RecordFile {
        let channel = |name: &str, k: f64| Channel {
            name: name.into(),
            unit: Some("N".into()),
            node: None,
            direction: None,
            id_line: None,
            values: (0..n).map(|i| (i as f64 * k).sin() * 1e-3).collect(),
            lines: None,
        };
        RecordFile {
            path: "hit.csv".into(),
            format: Format::Csv { delimiter: b',' },
            dt_s: 1.0 / 64.0,
            start_s: 0.0,
            channels: vec![channel("force", 0.1), channel("acc1", 0.37)],
        }
    }

    /// `read_record` on the file against `parse_record` on its bytes.
    fn same_as_in_memory(path: &Path) {
        let bytes = std::fs::read(path).unwrap();
        for opts in [ReadOptions::default(), ReadOptions::with_fs_hz(64.0)] {
            let want = format!("{:?}", parse_record(&bytes, path, &opts));
            assert_eq!(format!("{:?}", read_record(path, &opts)), want);
            assert_eq!(
                format!("{:?}", read_content_kind(path).unwrap()),
                format!("{:?}", content_kind(&bytes))
            );
        }
    }

    #[test]
    fn files_read_as_their_content_parses() {
        let dir = tempfile::tempdir().unwrap();
        let rec = record(5000);
        // A CSV file far longer than the head, and a short one.
        let long = dir.path().join("long.csv");
        write_csv(&long, &rec).unwrap();
        assert!(std::fs::metadata(&long).unwrap().len() > 2 * HEAD_BYTES);
        same_as_in_memory(&long);
        let short = dir.path().join("short.csv");
        write_csv(&short, &record(3)).unwrap();
        same_as_in_memory(&short);
        // UFF, ASCII and binary, and after more blank lines than the head holds
        // (recognised from the whole content).
        for enc in [Uff58Encoding::Ascii, Uff58Encoding::Binary] {
            let uff = dir.path().join("hit.uff");
            write_uff58(&uff, &rec, enc).unwrap();
            same_as_in_memory(&uff);
            let mut padded = vec![b'\n'; 70_000];
            padded.extend(std::fs::read(&uff).unwrap());
            std::fs::write(&uff, padded).unwrap();
            same_as_in_memory(&uff);
            assert!(read_record(&uff, &ReadOptions::default()).is_ok());
        }
        // A header line longer than the head; a damaged long file.
        let wide = dir.path().join("wide.csv");
        let names: Vec<String> = (0..9000).map(|i| format!("acc{i}")).collect();
        let row = vec!["1"; 9000].join(",");
        std::fs::write(&wide, format!("{}\n{row}\n{row}\n", names.join(","))).unwrap();
        same_as_in_memory(&wide);
        let mut bytes = std::fs::read(&long).unwrap();
        let at = bytes.len() - 1000;
        bytes[at] = b'x';
        std::fs::write(&long, bytes).unwrap();
        same_as_in_memory(&long);
        // A missing file.
        let missing = dir.path().join("missing.csv");
        match read_record(&missing, &ReadOptions::default()) {
            Err(RecordError::Io { op: IoOp::Read, .. }) => {}
            other => panic!("{other:?}"),
        }
        assert!(read_content_kind(&missing).is_err());
    }

    #[test]
    fn frf_text_is_told_from_its_first_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.csv");
        let mut text = String::from(
            "frequency_hz,re H(acc@2:+X/hammer@2:+X) [g/N],im H(acc@2:+X/hammer@2:+X) [g/N]\n",
        );
        for k in 0..10_000 {
            text.push_str(&format!("{k},0.5,-1.0\n"));
        }
        std::fs::write(&path, text).unwrap();
        assert_eq!(read_content_kind(&path).unwrap(), ContentKind::Frf);
        same_as_in_memory(&path);
    }
}
