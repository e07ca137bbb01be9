//! Read a board's `MEMORY` regions from its linker memory map (`memory.x`),
//! so the image checks use the same numbers the linker used.

use std::fmt;

/// One `MEMORY` region: `NAME : ORIGIN = …, LENGTH = …`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Region {
    /// Region name (`FLASH`, `RAM`, …).
    pub name: String,
    /// First address.
    pub origin: u64,
    /// Size in bytes.
    pub length: u64,
}

impl Region {
    /// One past the last address.
    pub fn end(&self) -> u64 {
        self.origin + self.length
    }

    /// True if `addr` lies inside the region.
    pub fn contains(&self, addr: u64) -> bool {
        addr >= self.origin && addr < self.end()
    }
}

/// Why a memory map could not be read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MapError {
    /// No `MEMORY { … }` block.
    NoMemoryBlock,
    /// A region line that does not parse (line number, text).
    BadLine(usize, String),
    /// The map has no region of this name.
    Missing(&'static str),
}

impl fmt::Display for MapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoMemoryBlock => write!(f, "no MEMORY {{ … }} block"),
            Self::BadLine(n, t) => write!(f, "line {n}: cannot parse region `{t}`"),
            Self::Missing(name) => write!(f, "no {name} region"),
        }
    }
}

impl std::error::Error for MapError {}

/// The regions of the first `MEMORY { … }` block of `text`.
pub fn parse(text: &str) -> Result<Vec<Region>, MapError> {
    let text = strip_comments(text);
    let start = text.find("MEMORY").ok_or(MapError::NoMemoryBlock)?;
    let open = text[start..].find('{').ok_or(MapError::NoMemoryBlock)? + start;
    let close = text[open..].find('}').ok_or(MapError::NoMemoryBlock)? + open;
    let first_line = text[..open].lines().count();
    let mut regions = Vec::new();
    for (i, line) in text[open + 1..close].lines().enumerate() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let bad = || MapError::BadLine(first_line + i, line.to_string());
        regions.push(parse_region(line).ok_or_else(bad)?);
    }
    Ok(regions)
}

/// The region called `name`.
pub fn region<'a>(regions: &'a [Region], name: &'static str) -> Result<&'a Region, MapError> {
    regions
        .iter()
        .find(|r| r.name == name)
        .ok_or(MapError::Missing(name))
}

/// `NAME (attrs) : ORIGIN = n, LENGTH = n` (also `org`/`len`, `o`/`l`).
fn parse_region(line: &str) -> Option<Region> {
    let (head, tail) = line.split_once(':')?;
    let name = head.split('(').next()?.trim();
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return None;
    }
    let mut origin = None;
    let mut length = None;
    for part in tail.split(',') {
        let (key, value) = part.split_once('=')?;
        let value = parse_number(value.trim())?;
        match key.trim().to_ascii_uppercase().as_str() {
            "ORIGIN" | "ORG" | "O" => origin = Some(value),
            "LENGTH" | "LEN" | "L" => length = Some(value),
            _ => return None,
        }
    }
    Some(Region {
        name: name.to_string(),
        origin: origin?,
        length: length?,
    })
}

/// `0x1000`, `4096`, `4K`, `4M` (linker-script number syntax).
fn parse_number(s: &str) -> Option<u64> {
    let s = s.trim();
    let (digits, scale) = match s.chars().last()? {
        'K' | 'k' => (&s[..s.len() - 1], 1024),
        'M' | 'm' => (&s[..s.len() - 1], 1024 * 1024),
        _ => (s, 1),
    };
    let value = match digits
        .strip_prefix("0x")
        .or_else(|| digits.strip_prefix("0X"))
    {
        Some(hex) => u64::from_str_radix(&hex.replace('_', ""), 16).ok()?,
        None => digits.parse::<u64>().ok()?,
    };
    value.checked_mul(scale)
}

/// Remove `/* … */` comments (keeping line breaks, for line numbers).
fn strip_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find("/*") {
        out.push_str(&rest[..start]);
        match rest[start..].find("*/") {
            Some(end) => {
                let comment = &rest[start..start + end + 2];
                out.extend(comment.chars().filter(|&c| c == '\n'));
                rest = &rest[start + end + 2..];
            }
            None => {
                rest = "";
            }
        }
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_both_boards_maps() {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
        let qemu = std::fs::read_to_string(format!("{root}/src/board/qemu/memory.x")).unwrap();
        let regions = parse(&qemu).unwrap();
        assert_eq!(region(&regions, "FLASH").unwrap().origin, 0);
        assert_eq!(region(&regions, "FLASH").unwrap().length, 4 << 20);
        assert_eq!(region(&regions, "RAM").unwrap().origin, 0x2000_0000);
        assert_eq!(region(&regions, "RAM").unwrap().length, 4 << 20);

        let nucleo = std::fs::read_to_string(format!("{root}/src/board/nucleo/memory.x")).unwrap();
        let regions = parse(&nucleo).unwrap();
        assert_eq!(region(&regions, "FLASH").unwrap().origin, 0x0800_0000);
        assert_eq!(region(&regions, "FLASH").unwrap().length, 2 << 20);
        // DTCM (src/board/nucleo/memory.x says why not the AXI SRAM).
        assert_eq!(region(&regions, "RAM").unwrap().origin, 0x2000_0000);
        assert_eq!(region(&regions, "RAM").unwrap().length, 128 << 10);
    }

    #[test]
    fn syntax_variants_and_errors() {
        let text = "/* c { } */ MEMORY {\n  FLASH (rx) : ORIGIN = 0x0800_0000, LENGTH = 128K\n\
                    /* x */ RAM : org = 536870912, len = 0x5000\n}";
        let r = parse(text).unwrap();
        assert_eq!(
            r,
            vec![
                Region {
                    name: "FLASH".into(),
                    origin: 0x0800_0000,
                    length: 128 * 1024
                },
                Region {
                    name: "RAM".into(),
                    origin: 0x2000_0000,
                    length: 0x5000
                },
            ]
        );
        assert!(r[1].contains(0x2000_4FFF) && !r[1].contains(0x2000_5000));
        assert_eq!(parse("INCLUDE x.x"), Err(MapError::NoMemoryBlock));
        assert!(matches!(
            parse("MEMORY {\n FLASH : ORIGIN = zz, LENGTH = 1K\n}"),
            Err(MapError::BadLine(2, _))
        ));
        assert_eq!(region(&r, "CCM"), Err(MapError::Missing("CCM")));
    }
}
