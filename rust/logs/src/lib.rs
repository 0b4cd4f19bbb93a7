//! Readers and writers of phone logs: fpbp native v1, Microsoft ILC 2.0
//! traces and IPIN GetSensorData logfiles.
//!
//! Readers stream (one line at a time, never the whole file), read gzip
//! transparently (detected from the magic bytes) and detect the format from
//! the content. They hand out [`LogEvent`]s in time order: a bounded reorder
//! buffer ([`ReadOptions::reorder_window_s`]) fixes rows written slightly out
//! of order and drops exact duplicates. Everything odd is counted in a
//! [`ReadReport`]; in strict mode the first malformed line is an error naming
//! the file and line.
//!
//! ```no_run
//! # use fpbp_logs::{open_log, ReadOptions};
//! let mut reader = open_log("walk.txt.gz".as_ref(), &ReadOptions::default()).unwrap();
//! for event in reader.by_ref() { /* ... */ }
//! println!("{:?}", reader.report());
//! ```
#![forbid(unsafe_code)]

pub mod error;
pub mod ilc;
pub mod ipin;
pub mod line;
pub mod native;
pub mod options;
pub mod reorder;
pub mod report;
pub mod wifi_group;

use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use fpbp_core::events::LogEvent;

pub use error::LogError;
pub use line::LineOutcome;
pub use native::{NativeHeader, NativeWriter};
pub use options::{LogFormat, ReadOptions};
pub use reorder::{Pushed, ReorderBuffer};
pub use report::{KindCounts, ReadReport};

/// Lines looked at to detect the format.
const DETECT_LINES: usize = 200;

enum Parser {
    Native(native::NativeParser),
    Ilc(ilc::IlcParser),
    Ipin(ipin::IpinParser),
}

impl Parser {
    fn parse_line(&mut self, line: &str) -> LineOutcome {
        match self {
            Parser::Native(p) => p.parse_line(line),
            Parser::Ilc(p) => p.parse_line(line),
            Parser::Ipin(p) => p.parse_line(line),
        }
    }
}

/// Opens a log file (plain or gzip) and detects its format.
pub fn open_log(path: &Path, opts: &ReadOptions) -> Result<LogReader, LogError> {
    let file = path.display().to_string();
    let f = std::fs::File::open(path).map_err(|source| LogError::Io {
        file: file.clone(),
        source,
    })?;
    LogReader::from_reader(file, f, opts)
}

/// Reads a whole log into memory (convenience for small logs and tests).
pub fn read_all(path: &Path, opts: &ReadOptions) -> Result<(Vec<LogEvent>, ReadReport), LogError> {
    let mut r = open_log(path, opts)?;
    let mut v = Vec::new();
    while let Some(e) = r.try_next()? {
        v.push(e);
    }
    Ok((v, r.report()))
}

/// Wraps `r` in a gzip decoder when its first bytes are the gzip magic.
pub fn decompressing(r: impl Read + Send + 'static) -> std::io::Result<Box<dyn BufRead + Send>> {
    let mut b = BufReader::with_capacity(1 << 16, r);
    let is_gz = b.fill_buf()?.starts_with(&[0x1f, 0x8b]);
    Ok(if is_gz {
        Box::new(BufReader::with_capacity(
            1 << 16,
            flate2::read::MultiGzDecoder::new(b),
        ))
    } else {
        Box::new(b)
    })
}

/// Detects the format from one line, if it is decisive.
pub fn detect_line(line: &str) -> Option<LogFormat> {
    let l = line.trim_start_matches('\u{feff}');
    if native::parse_magic(l).is_some() {
        Some(LogFormat::Native)
    } else if ilc::looks_like(l) {
        Some(LogFormat::Ilc)
    } else if ipin::looks_like(l) {
        Some(LogFormat::Ipin)
    } else {
        None
    }
}

/// A streaming log reader. As an [`Iterator`] it yields events and stops at the
/// first fatal error (strict-mode malformed line, I/O error), which
/// [`LogReader::error`] and [`LogReader::finish`] then return; [`LogReader::try_next`]
/// returns errors directly.
pub struct LogReader {
    file: String,
    src: Box<dyn BufRead + Send>,
    parser: Parser,
    format: LogFormat,
    strict: bool,
    gap_threshold_ns: i64,
    reorder: ReorderBuffer,
    wifi: wifi_group::WifiGrouper,
    pending: VecDeque<String>,
    line_no: u64,
    eof: bool,
    failed: bool,
    error: Option<LogError>,
    report: ReadReport,
    buf: Vec<u8>,
}

impl LogReader {
    /// A reader over any byte stream (plain or gzip); `file` names it in errors.
    pub fn from_reader(
        file: impl Into<String>,
        r: impl Read + Send + 'static,
        opts: &ReadOptions,
    ) -> Result<LogReader, LogError> {
        let file = file.into();
        let io = |source| LogError::Io {
            file: file.clone(),
            source,
        };
        let mut src = decompressing(r).map_err(io)?;
        let mut pending = VecDeque::new();
        let mut buf = Vec::new();
        let mut format = opts.format;
        while format.is_none() && pending.len() < DETECT_LINES {
            buf.clear();
            if src.read_until(b'\n', &mut buf).map_err(io)? == 0 {
                break;
            }
            let line = String::from_utf8_lossy(&buf).into_owned();
            format = detect_line(&line);
            pending.push_back(line);
        }
        let Some(format) = format else {
            return Err(LogError::UnknownFormat { file });
        };
        let parser = match format {
            LogFormat::Native => Parser::Native(native::NativeParser::new(opts.default_floor)),
            LogFormat::Ilc => Parser::Ilc(ilc::IlcParser::new(opts.default_floor)),
            LogFormat::Ipin => Parser::Ipin(ipin::IpinParser::new(opts.site_georef)),
        };
        let window_ns = if opts.reorder_window_s.is_finite() {
            (opts.reorder_window_s.max(0.0) * 1e9) as i64
        } else {
            0
        };
        let gap_threshold_ns = if opts.gap_threshold_s.is_finite() {
            (opts.gap_threshold_s.max(0.0) * 1e9) as i64
        } else {
            i64::MAX
        };
        Ok(LogReader {
            report: ReadReport {
                file: file.clone(),
                format: Some(format),
                ..Default::default()
            },
            file,
            src,
            parser,
            format,
            strict: opts.strict,
            gap_threshold_ns,
            reorder: ReorderBuffer::new(window_ns),
            wifi: wifi_group::WifiGrouper::default(),
            pending,
            line_no: 0,
            eof: false,
            failed: false,
            error: None,
            buf,
        })
    }

    /// The detected (or forced) format.
    pub fn format(&self) -> LogFormat {
        self.format
    }

    /// The file name this reader reports in errors.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The native header's metadata read so far (native logs only).
    pub fn native_header(&self) -> Option<&NativeHeader> {
        match &self.parser {
            Parser::Native(p) => Some(&p.header),
            _ => None,
        }
    }

    /// Native logs: the version of the header line (1 or 2), once read.
    pub fn native_version(&self) -> Option<u32> {
        match &self.parser {
            Parser::Native(p) => p.version,
            _ => None,
        }
    }

    /// ILC traces: the epoch time (ms) that t_ns = 0 stands for.
    pub fn ilc_origin_ms(&self) -> Option<i64> {
        match &self.parser {
            Parser::Ilc(p) => p.origin_ms(),
            _ => None,
        }
    }

    /// Counters so far (complete once the reader is exhausted).
    pub fn report(&self) -> ReadReport {
        let mut r = self.report.clone();
        match &self.parser {
            Parser::Ilc(p) => r.invalid_tx_power = p.invalid_tx_power,
            Parser::Ipin(p) => {
                r.orientation_check_max_deg = p.ahrs_max_mismatch_deg;
                r.device = p.device.clone();
            }
            Parser::Native(p) => r.device = p.header.meta.get("device").cloned(),
        }
        r
    }

    /// The fatal error that ended iteration, if any.
    pub fn error(&self) -> Option<&LogError> {
        self.error.as_ref()
    }

    /// Drains the reader and returns its report, or the fatal error.
    pub fn finish(mut self) -> Result<ReadReport, LogError> {
        while self.next().is_some() {}
        match self.error.take() {
            Some(e) => Err(e),
            None => Ok(self.report()),
        }
    }

    fn next_line(&mut self) -> Result<Option<String>, LogError> {
        if let Some(l) = self.pending.pop_front() {
            return Ok(Some(l));
        }
        self.buf.clear();
        match self.src.read_until(b'\n', &mut self.buf) {
            Ok(0) => Ok(None),
            Ok(_) => Ok(Some(String::from_utf8_lossy(&self.buf).into_owned())),
            Err(source) => Err(LogError::Io {
                file: self.file.clone(),
                source,
            }),
        }
    }

    /// The next event in time order; `Ok(None)` at the end.
    pub fn try_next(&mut self) -> Result<Option<LogEvent>, LogError> {
        if self.failed {
            return Ok(None);
        }
        match self.advance() {
            Ok(e) => Ok(e),
            Err(e) => {
                self.failed = true;
                if let LogError::Io { .. } = &e {
                    self.report.io_error = Some(e.to_string());
                }
                Err(e)
            }
        }
    }

    fn advance(&mut self) -> Result<Option<LogEvent>, LogError> {
        loop {
            if let Some(e) = self.reorder.pop_ready() {
                return Ok(Some(self.emit(e)));
            }
            if self.eof {
                return Ok(self.reorder.pop_any().map(|e| self.emit(e)));
            }
            let Some(line) = self.next_line()? else {
                self.eof = true;
                if let Some(scan) = self.wifi.take() {
                    self.accept(LogEvent::Wifi(scan));
                }
                continue;
            };
            self.line_no += 1;
            self.report.lines += 1;
            if self.line_no == 1
                && self.format == LogFormat::Native
                && let Some(v) = native::parse_magic(line.trim_start_matches('\u{feff}'))
                && !native::READ_VERSIONS.iter().any(|k| v == k.to_string())
            {
                return Err(LogError::UnsupportedVersion {
                    file: self.file.clone(),
                    line: 1,
                    version: v.to_string(),
                });
            }
            match self.parser.parse_line(&line) {
                LineOutcome::Header => self.report.header_lines += 1,
                LineOutcome::Ignored => self.report.ignored_records += 1,
                LineOutcome::TruthWithoutGeoref => {
                    if self.report.truth_without_georef == 0 {
                        log::warn!(
                            "{}:{}: lat/lon truth point skipped: no site georeference given",
                            self.file,
                            self.line_no
                        );
                    }
                    self.report.truth_without_georef += 1;
                }
                LineOutcome::Malformed(msg) => self.malformed(msg, false)?,
                LineOutcome::MalformedWifi(msg) => self.malformed(msg, true)?,
                LineOutcome::WifiRow { t_ns, result } => {
                    self.report.wifi_rows += 1;
                    if !result.rssi_dbm.is_finite() {
                        self.report.non_finite_dropped += 1;
                        continue;
                    }
                    match self.wifi.push(t_ns, result) {
                        Ok(Some(scan)) => self.accept(LogEvent::Wifi(scan)),
                        Ok(None) => {}
                        Err(msg) => self.malformed(msg, true)?,
                    }
                }
                LineOutcome::Event(e) => {
                    // a WiFi scan ends at the first other event
                    if let Some(scan) = self.wifi.take() {
                        self.accept(LogEvent::Wifi(scan));
                    }
                    self.accept(e);
                }
            }
        }
    }

    /// Counts (lenient) or returns (strict) a malformed line.
    fn malformed(&mut self, msg: String, wifi: bool) -> Result<(), LogError> {
        let err = LogError::Malformed {
            file: self.file.clone(),
            line: self.line_no,
            msg,
        };
        if self.strict {
            return Err(err);
        }
        self.report.malformed_skipped += 1;
        if self.report.first_malformed.is_none() {
            self.report.first_malformed = Some(err.to_string());
        }
        if wifi {
            self.report.malformed_wifi_rows += 1;
            if self.report.first_malformed_wifi.is_none() {
                self.report.first_malformed_wifi = Some(err.to_string());
            }
        }
        Ok(())
    }

    /// Hands a parsed event to the reorder buffer (dropping non-finite ones).
    fn accept(&mut self, e: LogEvent) {
        if !line::is_finite(&e) {
            self.report.non_finite_dropped += 1;
            return;
        }
        match self.reorder.push(e) {
            Pushed::InOrder => {}
            Pushed::Backwards => self.report.backwards_timestamps += 1,
            Pushed::Duplicate => self.report.duplicates_dropped += 1,
            Pushed::TooLate => {
                self.report.backwards_timestamps += 1;
                self.report.late_dropped += 1;
            }
        }
    }

    fn emit(&mut self, e: LogEvent) -> LogEvent {
        let t = e.t_ns();
        if let Some(last) = self.report.last_t_ns {
            let gap = t.saturating_sub(last);
            if gap > self.gap_threshold_ns {
                self.report.gaps_over_threshold += 1;
            }
            self.report.max_gap_s = self.report.max_gap_s.max(gap as f64 * 1e-9);
        }
        self.report.first_t_ns.get_or_insert(t);
        self.report.last_t_ns = Some(t);
        self.report.events.add(&e);
        e
    }
}

impl Iterator for LogReader {
    type Item = LogEvent;

    fn next(&mut self) -> Option<LogEvent> {
        match self.try_next() {
            Ok(e) => e,
            Err(err) => {
                log::warn!("{err}");
                self.error = Some(err);
                None
            }
        }
    }
}

#[cfg(test)]
mod tests;
