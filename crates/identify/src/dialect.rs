//! The CSV dialect of a log: field separator and decimal mark, given or detected.
//!
//! Spreadsheets and SCADA exports in much of Europe write `;` (or a tab) between fields and a
//! decimal comma (`12,5`), since the comma is their decimal mark. Detection reads the header
//! and the first [`SAMPLE_LINES`] rows:
//! - separator: of tab, `;` and `,`, the ones that split the header into two or more fields
//!   and every sampled row into as many (outside quotes); of those, the one giving the most
//!   fields, ties resolved in that order (tab, `;`, `,`); none: `,`;
//! - decimal mark: with `,` as separator, the point; otherwise the comma if some sampled
//!   field is a number written with a decimal comma (`-0,5`, `1,25e3`) and none with a
//!   decimal point, else the point.
//!
//! A given separator or decimal mark is used as given. A UTF-8 byte order mark before the
//! header (Excel's "CSV UTF-8") is skipped.

use std::fmt;

/// Rows after the header that detection looks at.
pub const SAMPLE_LINES: usize = 50;

/// The separators tried, in order of preference on a tie.
const SEPARATORS: [u8; 3] = [b'\t', b';', b','];

/// The character between a number's integer and fractional digits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecimalMark {
    /// `12.5`.
    Point,
    /// `12,5`.
    Comma,
}

/// How the fields of a log are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Dialect {
    /// Field separator (a byte: `,`, `;`, tab or another ASCII character).
    pub separator: u8,
    /// Decimal mark of numbers.
    pub decimal: DecimalMark,
}

impl Default for Dialect {
    fn default() -> Self {
        Dialect {
            separator: b',',
            decimal: DecimalMark::Point,
        }
    }
}

impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let separator = match self.separator {
            b'\t' => "tab".to_string(),
            c => format!("`{}`", c as char),
        };
        let decimal = match self.decimal {
            DecimalMark::Point => "decimal point",
            DecimalMark::Comma => "decimal comma",
        };
        write!(f, "{separator}-separated, {decimal}")
    }
}

/// What the user gave: each part None to detect it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DialectChoice {
    /// Field separator, or None to detect it.
    pub separator: Option<u8>,
    /// Decimal mark, or None to detect it.
    pub decimal: Option<DecimalMark>,
}

impl DialectChoice {
    /// Parses `--separator`: `auto`, `comma`, `semicolon`, `tab` or one ASCII character.
    pub fn parse_separator(text: &str) -> Result<Option<u8>, String> {
        match text {
            "auto" => Ok(None),
            "comma" => Ok(Some(b',')),
            "semicolon" => Ok(Some(b';')),
            "tab" | "\t" => Ok(Some(b'\t')),
            c if c.len() == 1 && c.is_ascii() && !c.as_bytes()[0].is_ascii_alphanumeric() && c != "\"" && c != "." => {
                Ok(Some(c.as_bytes()[0]))
            }
            other => Err(format!(
                "--separator `{other}`: give auto, comma, semicolon, tab or one punctuation character"
            )),
        }
    }

    /// Parses `--decimal`: `auto`, `point` (or `.`) or `comma` (or `,`).
    pub fn parse_decimal(text: &str) -> Result<Option<DecimalMark>, String> {
        match text {
            "auto" => Ok(None),
            "point" | "." => Ok(Some(DecimalMark::Point)),
            "comma" | "," => Ok(Some(DecimalMark::Comma)),
            other => Err(format!("--decimal `{other}`: give auto, point or comma")),
        }
    }

    /// The dialect of a file beginning with `head` (the header and some rows; a last line cut
    /// short is ignored), with the given parts as given. Errors if both marks are commas.
    pub fn resolve(self, head: &[u8]) -> Result<Dialect, String> {
        let lines: Vec<&[u8]> = split_lines(head);
        let separator = self.separator.unwrap_or_else(|| detect_separator(&lines));
        let decimal = match (self.decimal, separator) {
            (Some(mark), _) => mark,
            (None, b',') => DecimalMark::Point,
            (None, sep) => detect_decimal(&lines, sep),
        };
        if separator == b',' && decimal == DecimalMark::Comma {
            return Err("the comma cannot be both the separator and the decimal mark: give --separator semicolon or tab".into());
        }
        Ok(Dialect { separator, decimal })
    }
}

/// The header and the sampled rows of `head`: complete lines only (the last one is dropped
/// when `head` does not end with a newline and holds more than one line), without a BOM.
fn split_lines(head: &[u8]) -> Vec<&[u8]> {
    let head = head.strip_prefix(b"\xef\xbb\xbf").unwrap_or(head);
    let mut lines: Vec<&[u8]> = head
        .split(|&b| b == b'\n')
        .map(|l| l.strip_suffix(b"\r").unwrap_or(l))
        .collect();
    if lines.len() > 1 {
        lines.pop(); // After the last '\n': empty, or a line cut short.
    }
    lines.retain(|l| !l.iter().all(u8::is_ascii_whitespace));
    lines.truncate(SAMPLE_LINES + 1);
    lines
}

/// Separators outside double quotes in `line`.
fn count_outside_quotes(line: &[u8], separator: u8) -> usize {
    let mut quoted = false;
    line.iter()
        .filter(|&&b| {
            if b == b'"' {
                quoted = !quoted;
            }
            b == separator && !quoted
        })
        .count()
}

fn detect_separator(lines: &[&[u8]]) -> u8 {
    let Some((header, rows)) = lines.split_first() else {
        return b',';
    };
    let mut best: Option<(usize, u8)> = None;
    for sep in SEPARATORS {
        let n = count_outside_quotes(header, sep);
        let consistent = n > 0 && rows.iter().all(|row| count_outside_quotes(row, sep) == n);
        if consistent && best.is_none_or(|(m, _)| n > m) {
            best = Some((n, sep));
        }
    }
    best.map_or(b',', |(_, sep)| sep)
}

fn detect_decimal(lines: &[&[u8]], separator: u8) -> DecimalMark {
    let (mut comma, mut point) = (false, false);
    for row in lines.iter().skip(1) {
        for field in row.split(|&b| b == separator) {
            let text = String::from_utf8_lossy(field);
            let text = text.trim().trim_matches('"');
            comma |= is_number_with(text, ',');
            point |= is_number_with(text, '.');
        }
    }
    if comma && !point {
        DecimalMark::Comma
    } else {
        DecimalMark::Point
    }
}

/// `text` is a number with `mark` between integer and fractional digits: `[-+]d+<mark>d+`
/// with an optional exponent `e[-+]d+`.
fn is_number_with(text: &str, mark: char) -> bool {
    let body = text.strip_prefix(['-', '+']).unwrap_or(text);
    let (mantissa, exponent) = match body.find(['e', 'E']) {
        Some(i) => (&body[..i], Some(&body[i + 1..])),
        None => (body, None),
    };
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let exponent_ok = exponent.is_none_or(|e| digits(e.strip_prefix(['-', '+']).unwrap_or(e)));
    match mantissa.split_once(mark) {
        Some((int, frac)) => digits(int) && digits(frac) && exponent_ok,
        None => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn detect(text: &str) -> Dialect {
        DialectChoice::default().resolve(text.as_bytes()).unwrap()
    }

    #[test]
    fn separators_and_decimal_marks_are_detected() {
        let comma = Dialect {
            separator: b',',
            decimal: DecimalMark::Point,
        };
        assert_eq!(detect("time,current\n0,53.35\n1,53.4\n"), comma);
        assert_eq!(
            detect("time;current\n0;53,35\n1;53,4\n"),
            Dialect {
                separator: b';',
                decimal: DecimalMark::Comma
            }
        );
        assert_eq!(
            detect("time\tcurrent\n0\t53,35\n"),
            Dialect {
                separator: b'\t',
                decimal: DecimalMark::Comma
            }
        );
        assert_eq!(
            detect("time;current\n0;53.35\n"),
            Dialect {
                separator: b';',
                decimal: DecimalMark::Point
            }
        );
        // Integers only: nothing tells, the point is assumed (and parses them alike).
        assert_eq!(
            detect("time;current\n0;53\n1;54\n"),
            Dialect {
                separator: b';',
                decimal: DecimalMark::Point
            }
        );
        // A comma inside the header names of a `;` file does not make it comma-separated.
        assert_eq!(detect("time [s];current [A, DC]\n0;1,5\n").separator, b';');
        // Quoted separators do not count.
        assert_eq!(detect("time,\"note; free text\"\n0,\"a; b\"\n"), comma);
        // Timestamps with fractional seconds are not decimal numbers.
        assert_eq!(
            detect("time;current\n2025-10-22T08:00:00.5Z;53,35\n").decimal,
            DecimalMark::Comma
        );
    }

    #[test]
    fn a_bom_crlf_and_a_cut_last_line_do_not_confuse_detection() {
        let d = detect("\u{feff}time;current\r\n0;53,35\r\n1;53,");
        assert_eq!(
            d,
            Dialect {
                separator: b';',
                decimal: DecimalMark::Comma
            }
        );
        assert_eq!(detect("time"), Dialect::default());
        assert_eq!(detect(""), Dialect::default());
    }

    #[test]
    fn given_parts_win_and_contradictions_are_refused() {
        let given = DialectChoice {
            separator: Some(b';'),
            decimal: None,
        };
        assert_eq!(
            given.resolve(b"a|b\n1|2\n").unwrap(),
            Dialect {
                separator: b';',
                decimal: DecimalMark::Point
            }
        );
        let both = DialectChoice {
            separator: Some(b','),
            decimal: Some(DecimalMark::Comma),
        };
        assert!(both
            .resolve(b"")
            .unwrap_err()
            .contains("both the separator and the decimal mark"));
        assert_eq!(DialectChoice::parse_separator("semicolon"), Ok(Some(b';')));
        assert_eq!(DialectChoice::parse_separator("|"), Ok(Some(b'|')));
        assert!(DialectChoice::parse_separator("x").is_err());
        assert_eq!(
            DialectChoice::parse_decimal(","),
            Ok(Some(DecimalMark::Comma))
        );
        assert!(DialectChoice::parse_decimal("dot").is_err());
    }

    #[test]
    fn numbers_with_a_mark() {
        for yes in ["1,5", "-0,25", "+12,0", "1,25e3", "3,0E-2"] {
            assert!(is_number_with(yes, ','), "{yes}");
        }
        for no in ["1", "1,", ",5", "1,5,6", "a,b", "1,5e", "2025-10-22"] {
            assert!(!is_number_with(no, ','), "{no}");
        }
    }
}
