//! Reading operational logs: CSV files (or directories of daily files) into gap-free blocks
//! per module, skipping and counting bad rows.
//!
//! A data row is used when its time and every mapped numeric column parse as finite numbers
//! and its time is later than the previous used row of the same module in the same file.
//! Otherwise it is skipped and counted once, under the reason of its first bad field
//! ([`BadRow`]). A time step longer than [`ReadOptions::max_gap`] is a gap: it is counted and
//! closes the block, so no later step bridges it. Files are read in parallel. The separator and
//! decimal mark are given or detected per file ([`crate::dialect`]).

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use super::columns::{Channel, ColumnMap, MEASURED_CHANNELS};
use super::dialect::SAMPLE_LINES;
pub use super::dialect::{DecimalMark, Dialect, DialectChoice};
use super::error::{Error, Result};

/// Why a data row was skipped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BadRow {
    /// A used field is empty.
    EmptyField,
    /// A used field is `nan` or infinite.
    NotANumber,
    /// A used field is text that is neither a number nor (for time) an RFC 3339 timestamp.
    Text,
    /// The row has fewer fields than the header needs.
    ShortRow,
    /// The time equals the previous used row's.
    DuplicateTime,
    /// The time is earlier than the previous used row's.
    BackwardsTime,
}

impl BadRow {
    /// Every reason, in report order.
    pub const ALL: [BadRow; 6] = [
        BadRow::EmptyField,
        BadRow::NotANumber,
        BadRow::Text,
        BadRow::ShortRow,
        BadRow::DuplicateTime,
        BadRow::BackwardsTime,
    ];

    /// Short label for reports and JSON.
    pub const fn label(self) -> &'static str {
        match self {
            BadRow::EmptyField => "empty field",
            BadRow::NotANumber => "nan or infinite",
            BadRow::Text => "non-numeric text",
            BadRow::ShortRow => "missing fields",
            BadRow::DuplicateTime => "duplicated timestamp",
            BadRow::BackwardsTime => "backwards timestamp",
        }
    }
}

/// A place in the input, for messages.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    /// The file.
    pub path: PathBuf,
    /// 1-based line (the header is line 1).
    pub line: u64,
}

/// Skipped rows per reason, and gaps, with the first place each was seen.
#[derive(Clone, Debug, Default)]
pub struct BadRowCounts {
    counts: [u64; 6],
    first: [Option<Location>; 6],
    /// Number of gaps (time steps longer than the allowed maximum).
    pub gaps: u64,
    /// Total time missing in gaps [s].
    pub gap_seconds: f64,
    /// Where the first gap ends.
    pub first_gap: Option<Location>,
}

impl BadRowCounts {
    /// Rows skipped for `reason`.
    pub fn count(&self, reason: BadRow) -> u64 {
        self.counts[reason as usize]
    }

    /// First row skipped for `reason`.
    pub fn first(&self, reason: BadRow) -> Option<&Location> {
        self.first[reason as usize].as_ref()
    }

    /// All skipped rows.
    pub fn total(&self) -> u64 {
        self.counts.iter().sum()
    }

    fn add(&mut self, reason: BadRow, path: &Path, line: u64) {
        self.counts[reason as usize] += 1;
        if self.first[reason as usize].is_none() {
            self.first[reason as usize] = Some(Location {
                path: path.to_path_buf(),
                line,
            });
        }
    }

    fn merge(&mut self, other: &BadRowCounts) {
        for reason in BadRow::ALL {
            let i = reason as usize;
            self.counts[i] += other.counts[i];
            if self.first[i].is_none() {
                self.first[i].clone_from(&other.first[i]);
            }
        }
        self.gaps += other.gaps;
        self.gap_seconds += other.gap_seconds;
        if self.first_gap.is_none() {
            self.first_gap.clone_from(&other.first_gap);
        }
    }
}

/// Consecutive used rows of one module without a gap: columns of equal length.
#[derive(Clone, Debug)]
pub struct Block {
    /// File the rows come from.
    pub source: PathBuf,
    /// Line of the block's first row.
    pub first_line: u64,
    /// Time [s] (seconds since the Unix epoch for RFC 3339 timestamps), strictly increasing.
    pub time: Vec<f64>,
    /// Values of [`Channel::MEASURED`] in that order; `None` where the file has no such column.
    pub channels: [Option<Vec<f64>>; MEASURED_CHANNELS],
}

impl Block {
    /// The values of a measured channel, if the file has it.
    pub fn channel(&self, channel: Channel) -> Option<&[f64]> {
        channel.index().and_then(|i| self.channels[i].as_deref())
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// True without rows.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }
}

/// Everything read for one module.
#[derive(Clone, Debug, Default)]
pub struct ModuleLog {
    /// Module identifier (the module column's value, or the file set's name).
    pub id: String,
    /// Gap-free blocks, sorted by their first time.
    pub blocks: Vec<Block>,
    /// Skipped rows and gaps.
    pub bad: BadRowCounts,
    /// Data rows read (header excluded).
    pub rows_read: u64,
    /// Rows used.
    pub rows_used: u64,
    /// Files that contributed rows.
    pub files: Vec<PathBuf>,
    /// The dialects the files were read with, each once, in order of first use.
    pub dialects: Vec<Dialect>,
}

impl ModuleLog {
    /// True if some block has `channel`.
    pub fn has(&self, channel: Channel) -> bool {
        self.blocks.iter().any(|b| b.channel(channel).is_some())
    }

    fn merge(&mut self, other: ModuleLog) {
        self.blocks.extend(other.blocks);
        self.bad.merge(&other.bad);
        self.rows_read += other.rows_read;
        self.rows_used += other.rows_used;
        self.files.extend(other.files);
        for d in other.dialects {
            if !self.dialects.contains(&d) {
                self.dialects.push(d);
            }
        }
    }
}

/// How to read the logs.
#[derive(Clone, Debug)]
pub struct ReadOptions {
    /// Column names.
    pub columns: ColumnMap,
    /// Longest time step that is not a gap [s].
    pub max_gap: f64,
    /// Module id for files without a module column.
    pub module: String,
    /// Field separator and decimal mark (detected per file where not given).
    pub dialect: DialectChoice,
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            columns: ColumnMap::default(),
            max_gap: 10.0,
            module: "module".into(),
            dialect: DialectChoice::default(),
        }
    }
}

/// The CSV files named: files as given, directories as their `*.csv` files sorted by name.
pub fn expand_inputs(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for path in paths {
        let meta = std::fs::metadata(path).map_err(|e| io_error(path, e))?;
        if meta.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(path)
                .map_err(|e| io_error(path, e))?
                .filter_map(|entry| entry.ok().map(|e| e.path()))
                .filter(|p| {
                    p.is_file() && p.extension().is_some_and(|x| x.eq_ignore_ascii_case("csv"))
                })
                .collect();
            if found.is_empty() {
                return Err(Error::Input(format!(
                    "{}: directory holds no .csv file",
                    path.display()
                )));
            }
            found.sort();
            files.extend(found);
        } else {
            files.push(path.clone());
        }
    }
    if files.is_empty() {
        return Err(Error::Input("no input file given".into()));
    }
    Ok(files)
}

/// Reads `files` (in parallel) and merges them per module, in order of module id.
/// `on_file` is called once per file read (for a progress bar).
pub fn read_files(
    files: &[PathBuf],
    options: &ReadOptions,
    on_file: &(dyn Fn() + Sync),
) -> Result<Vec<ModuleLog>> {
    let workers = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(files.len())
        .max(1);
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Result<Vec<ModuleLog>>>>> =
        Mutex::new((0..files.len()).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(path) = files.get(i) else { break };
                let result = read_file(path, options);
                on_file();
                if let Ok(mut slots) = results.lock() {
                    slots[i] = Some(result);
                }
            });
        }
    });
    let slots = results
        .into_inner()
        .map_err(|_| Error::Input("a reader thread failed".into()))?;
    let mut by_module: Vec<ModuleLog> = Vec::new();
    for (i, slot) in slots.into_iter().enumerate() {
        let logs =
            slot.ok_or_else(|| Error::Input(format!("{}: not read", files[i].display())))??;
        for log in logs {
            match by_module.iter_mut().find(|m| m.id == log.id) {
                Some(m) => m.merge(log),
                None => by_module.push(log),
            }
        }
    }
    for m in &mut by_module {
        m.blocks.sort_by(|a, b| a.time[0].total_cmp(&b.time[0]));
    }
    by_module.sort_by(|a, b| a.id.cmp(&b.id));
    Ok(by_module)
}

/// Reads one CSV file into one [`ModuleLog`] per module id found in it.
pub fn read_file(path: &Path, options: &ReadOptions) -> Result<Vec<ModuleLog>> {
    let file = File::open(path).map_err(|e| io_error(path, e))?;
    read_csv(file, path, options)
}

/// The header and the first [`SAMPLE_LINES`] rows of `source`, for dialect detection.
fn read_head(source: &mut impl BufRead, path: &Path) -> Result<Vec<u8>> {
    let mut head = Vec::new();
    for _ in 0..=SAMPLE_LINES {
        let n = source
            .read_until(b'\n', &mut head)
            .map_err(|e| io_error(path, e))?;
        if n == 0 {
            break;
        }
    }
    Ok(head)
}

/// Reads CSV text from `source` into one [`ModuleLog`] per module id found in it; `path`
/// names it in messages and in the logs' blocks.
pub fn read_csv(source: impl Read, path: &Path, options: &ReadOptions) -> Result<Vec<ModuleLog>> {
    Ok(read_csv_with_dialect(source, path, options)?.0)
}

/// [`read_csv`], also giving the dialect the file was read with.
pub fn read_csv_with_dialect(
    source: impl Read,
    path: &Path,
    options: &ReadOptions,
) -> Result<(Vec<ModuleLog>, Dialect)> {
    let mut source = BufReader::new(source);
    let mut head = read_head(&mut source, path)?;
    let dialect = options
        .dialect
        .resolve(&head)
        .map_err(|message| Error::Content {
            path: path.into(),
            line: 1,
            message,
        })?;
    if head.starts_with(b"\xef\xbb\xbf") {
        head.drain(..3); // A UTF-8 byte order mark is no part of the first column's name.
    }
    let mut reader = csv::ReaderBuilder::new()
        .flexible(true)
        .has_headers(false)
        .delimiter(dialect.separator)
        .from_reader(std::io::Cursor::new(head).chain(source));
    let mut record = csv::ByteRecord::new();
    let header_ok = reader
        .read_byte_record(&mut record)
        .map_err(|e| csv_error(path, &e))?;
    if !header_ok {
        return Err(Error::Content {
            path: path.into(),
            line: 1,
            message: "empty file: no header row".into(),
        });
    }
    let header: Vec<String> = record
        .iter()
        .map(|f| String::from_utf8_lossy(f).trim().to_string())
        .collect();
    let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
    let index = options.columns.locate(&header_refs);
    for required in [Channel::Time, Channel::Current] {
        if index[required as usize].is_none() {
            return Err(Error::Content {
                path: path.into(),
                line: 1,
                message: format!(
                    "no column `{}` for {} [{}] (columns: {}; read as {dialect}); map one with --column {}=NAME{}",
                    options.columns.name(required),
                    required,
                    required.unit(),
                    header.join(", "),
                    required.key(),
                    if header.len() < 2 { " or give the separator with --separator" } else { "" }
                ),
            });
        }
    }
    let time_col = index[Channel::Time as usize].unwrap_or(0);
    let module_col = index[Channel::Module as usize];
    let measured: Vec<(usize, usize)> = Channel::MEASURED
        .iter()
        .enumerate()
        .filter_map(|(slot, c)| index[*c as usize].map(|col| (slot, col)))
        .collect();
    let present: [bool; MEASURED_CHANNELS] =
        std::array::from_fn(|slot| measured.iter().any(|&(s, _)| s == slot));
    let needed = measured
        .iter()
        .map(|&(_, c)| c)
        .chain([time_col])
        .chain(module_col)
        .max()
        .unwrap_or(0)
        + 1;

    let mut builders: HashMap<String, Builder> = HashMap::new();
    let mut rows_read = 0u64;
    let mut values = [0.0f64; MEASURED_CHANNELS];
    loop {
        match reader.read_byte_record(&mut record) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => return Err(csv_error(path, &e)),
        }
        rows_read += 1;
        let line = record.position().map_or(rows_read + 1, |p| p.line());
        let module: &str = match module_col {
            Some(c) => match record.get(c).map(|f| std::str::from_utf8(f).map(str::trim)) {
                Some(Ok(id)) if !id.is_empty() => id,
                // The row's module is unknown: count it against the file's default module.
                Some(Ok(_)) => {
                    builder(&mut builders, &options.module, path, &present)
                        .bad
                        .add(BadRow::EmptyField, path, line);
                    continue;
                }
                Some(Err(_)) => {
                    builder(&mut builders, &options.module, path, &present)
                        .bad
                        .add(BadRow::Text, path, line);
                    continue;
                }
                None => {
                    builder(&mut builders, &options.module, path, &present)
                        .bad
                        .add(BadRow::ShortRow, path, line);
                    continue;
                }
            },
            None => &options.module,
        };
        let b = builder(&mut builders, module, path, &present);
        if record.len() < needed {
            b.bad.add(BadRow::ShortRow, path, line);
            continue;
        }
        let parsed = parse_time_in(record.get(time_col).unwrap_or_default(), dialect.decimal)
            .and_then(|t| {
                for &(slot, col) in &measured {
                    values[slot] =
                        parse_number_in(record.get(col).unwrap_or_default(), dialect.decimal)?;
                }
                Ok(t)
            });
        match parsed {
            Ok(t) => b.push(t, &values, path, line, options.max_gap),
            Err(reason) => b.bad.add(reason, path, line),
        }
    }
    let mut logs: Vec<ModuleLog> = builders
        .into_iter()
        .map(|(id, b)| b.finish(id, path, dialect))
        .collect();
    debug_assert_eq!(logs.iter().map(|l| l.rows_read).sum::<u64>(), rows_read);
    logs.sort_by(|a, b| a.id.cmp(&b.id));
    Ok((logs, dialect))
}

fn builder<'a>(
    builders: &'a mut HashMap<String, Builder>,
    id: &str,
    path: &Path,
    present: &[bool; MEASURED_CHANNELS],
) -> &'a mut Builder {
    builders
        .entry(id.to_string())
        .or_insert_with(|| Builder::new(path, present))
}

/// Accumulates one module's rows of one file.
struct Builder {
    present: [bool; MEASURED_CHANNELS],
    current: Block,
    blocks: Vec<Block>,
    bad: BadRowCounts,
    rows_used: u64,
}

impl Builder {
    fn new(path: &Path, present: &[bool; MEASURED_CHANNELS]) -> Builder {
        Builder {
            present: *present,
            current: empty_block(path, 0, present),
            blocks: Vec::new(),
            bad: BadRowCounts::default(),
            rows_used: 0,
        }
    }

    fn push(
        &mut self,
        t: f64,
        values: &[f64; MEASURED_CHANNELS],
        path: &Path,
        line: u64,
        max_gap: f64,
    ) {
        if let Some(&last) = self.current.time.last() {
            if t == last {
                self.bad.add(BadRow::DuplicateTime, path, line);
                return;
            }
            if t < last {
                self.bad.add(BadRow::BackwardsTime, path, line);
                return;
            }
            if t - last > max_gap {
                self.bad.gaps += 1;
                self.bad.gap_seconds += t - last;
                if self.bad.first_gap.is_none() {
                    self.bad.first_gap = Some(Location {
                        path: path.into(),
                        line,
                    });
                }
                let next = empty_block(path, line, &self.present);
                self.blocks.push(std::mem::replace(&mut self.current, next));
            }
        }
        if self.current.time.is_empty() {
            self.current.first_line = line;
        }
        self.current.time.push(t);
        for (slot, column) in self.current.channels.iter_mut().enumerate() {
            if let Some(column) = column {
                column.push(values[slot]);
            }
        }
        self.rows_used += 1;
    }

    fn finish(mut self, id: String, path: &Path, dialect: Dialect) -> ModuleLog {
        self.blocks.push(self.current);
        self.blocks.retain(|b| !b.is_empty());
        ModuleLog {
            id,
            blocks: self.blocks,
            // Every data row is either used or counted once as bad.
            rows_read: self.rows_used + self.bad.total(),
            rows_used: self.rows_used,
            bad: self.bad,
            files: vec![path.to_path_buf()],
            dialects: vec![dialect],
        }
    }
}

fn empty_block(path: &Path, line: u64, present: &[bool; MEASURED_CHANNELS]) -> Block {
    Block {
        source: path.to_path_buf(),
        first_line: line,
        time: Vec::new(),
        channels: std::array::from_fn(|slot| present[slot].then(Vec::new)),
    }
}

/// A numeric field: finite number, or the reason it is not one.
pub fn parse_number(field: &[u8]) -> std::result::Result<f64, BadRow> {
    let text = std::str::from_utf8(field).map_err(|_| BadRow::Text)?.trim();
    if text.is_empty() {
        return Err(BadRow::EmptyField);
    }
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(BadRow::NotANumber),
        Err(_) => Err(BadRow::Text),
    }
}

/// [`parse_number`] for numbers written with `decimal` (`12,5` with a decimal comma; a field
/// holding a point then is text).
pub fn parse_number_in(field: &[u8], decimal: DecimalMark) -> std::result::Result<f64, BadRow> {
    match decimal {
        DecimalMark::Point => parse_number(field),
        DecimalMark::Comma => {
            if field.contains(&b'.') {
                return Err(if field.iter().all(u8::is_ascii_whitespace) {
                    BadRow::EmptyField
                } else {
                    BadRow::Text
                });
            }
            let mut pointed = [0u8; 64];
            if field.len() > pointed.len() {
                return Err(BadRow::Text);
            }
            for (out, &b) in pointed.iter_mut().zip(field) {
                *out = if b == b',' { b'.' } else { b };
            }
            parse_number(&pointed[..field.len()])
        }
    }
}

/// A time field [s]: seconds as a number, or an RFC 3339 timestamp as seconds since the Unix
/// epoch (e.g. `2025-10-22T08:00:01.5+02:00`).
pub fn parse_time(field: &[u8]) -> std::result::Result<f64, BadRow> {
    parse_time_in(field, DecimalMark::Point)
}

/// [`parse_time`] with seconds written with `decimal` (timestamps keep RFC 3339's point).
pub fn parse_time_in(field: &[u8], decimal: DecimalMark) -> std::result::Result<f64, BadRow> {
    match parse_number_in(field, decimal) {
        Err(BadRow::Text) => {}
        other => return other,
    }
    let text = std::str::from_utf8(field).map_err(|_| BadRow::Text)?.trim();
    let stamp = chrono::DateTime::parse_from_rfc3339(text).map_err(|_| BadRow::Text)?;
    Ok(stamp.timestamp() as f64 + f64::from(stamp.timestamp_subsec_nanos()) * 1e-9)
}

fn io_error(path: &Path, e: std::io::Error) -> Error {
    Error::Io {
        path: path.into(),
        message: e.to_string(),
    }
}

fn csv_error(path: &Path, e: &csv::Error) -> Error {
    let line = e.position().map_or(0, |p| p.line());
    Error::Content {
        path: path.into(),
        line,
        message: format!("cannot read CSV: {e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_and_their_failures() {
        assert_eq!(parse_number(b" 12.5 "), Ok(12.5));
        assert_eq!(parse_number(b""), Err(BadRow::EmptyField));
        assert_eq!(parse_number(b"  "), Err(BadRow::EmptyField));
        assert_eq!(parse_number(b"nan"), Err(BadRow::NotANumber));
        assert_eq!(parse_number(b"-inf"), Err(BadRow::NotANumber));
        assert_eq!(parse_number(b"n/a"), Err(BadRow::Text));
        assert_eq!(parse_number(b"\xff\xfe"), Err(BadRow::Text));
    }

    #[test]
    fn rfc3339_timestamps_with_offsets_and_fractions() {
        let utc = parse_time(b"2025-10-22T08:00:00Z").unwrap();
        assert_eq!(utc, 1_761_120_000.0);
        assert_eq!(
            parse_time(b"2025-10-22T10:00:01.5+02:00").unwrap(),
            utc + 1.5
        );
        assert_eq!(parse_time(b"17.25"), Ok(17.25));
        assert_eq!(parse_time(b"2025-13-22T08:00:00Z"), Err(BadRow::Text));
        assert_eq!(parse_time(b"NaN"), Err(BadRow::NotANumber));
    }
}
