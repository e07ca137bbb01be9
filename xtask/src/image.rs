//! Size and sanity of a linked firmware image (ELF), against its board's
//! memory map.

use std::fmt;

use object::{Object, ObjectSection, ObjectSymbol, SectionFlags, SectionKind, SymbolKind};

use crate::memory_map::Region;

/// What an image occupies.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Footprint {
    /// Bytes stored in flash: every allocated section with contents (vector
    /// table, .text, .rodata, and .data's initial values).
    pub flash: u64,
    /// Static RAM: allocated sections placed in RAM (.data, .bss,
    /// .uninit). The stack is not a section and is not counted.
    pub ram: u64,
    /// Bytes used in each further RAM region of the map (e.g. the H743's
    /// AXISRAM, SRAM123), in the map's order.
    pub other_ram: Vec<(String, u64)>,
    /// Initial stack pointer (vector table word 0).
    pub initial_sp: u64,
    /// Reset vector (vector table word 1), thumb bit included.
    pub reset: u64,
    /// `(name, address, size)` of each allocated section.
    pub sections: Vec<(String, u64, u64)>,
}

/// An image that does not fit or does not start.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ImageError {
    /// The file is not an ELF the `object` crate can read.
    Parse(String),
    /// No section starts at the flash origin (no vector table there).
    NoVectorTable(u64),
    /// An allocated section lies outside every region of the map.
    Outside(String, u64, u64),
    /// The initial stack pointer is not inside RAM (or not 8-byte aligned).
    StackPointer(u64),
    /// The reset vector is not a thumb address inside FLASH.
    ResetVector(u64),
}

impl fmt::Display for ImageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Parse(e) => write!(f, "cannot parse the ELF: {e}"),
            Self::NoVectorTable(a) => write!(f, "no section at the flash origin {a:#010x}"),
            Self::Outside(n, a, s) => {
                write!(
                    f,
                    "section {n} ({a:#010x}, {s} B) outside every region of the map"
                )
            }
            Self::StackPointer(sp) => {
                write!(
                    f,
                    "initial stack pointer {sp:#010x} not 8-byte aligned inside RAM"
                )
            }
            Self::ResetVector(r) => {
                write!(f, "reset vector {r:#010x} not a thumb address inside FLASH")
            }
        }
    }
}

impl std::error::Error for ImageError {}

/// Measure `elf` and check its vector table against `flash` and `ram`;
/// sections may also lie in the `other` regions (RAM the start-up code does
/// not initialise, placed by `#[link_section]`).
pub fn inspect(
    elf: &[u8],
    flash: &Region,
    ram: &Region,
    other: &[Region],
) -> Result<Footprint, ImageError> {
    let file = object::File::parse(elf).map_err(|e| ImageError::Parse(e.to_string()))?;
    let mut fp = Footprint {
        flash: 0,
        ram: 0,
        other_ram: other.iter().map(|r| (r.name.clone(), 0)).collect(),
        initial_sp: 0,
        reset: 0,
        sections: Vec::new(),
    };
    let mut vectors = None;
    for s in file.sections() {
        if !is_alloc(&s) {
            continue;
        }
        let (addr, size) = (s.address(), s.size());
        let name = s.name().unwrap_or("?").to_string();
        if size == 0 {
            continue;
        }
        let has_contents = s.kind() != SectionKind::UninitializedData;
        if has_contents {
            fp.flash += size;
        }
        if ram.contains(addr) {
            fp.ram += size;
        } else if let Some(i) = other.iter().position(|r| r.contains(addr)) {
            fp.other_ram[i].1 += size;
        } else if !flash.contains(addr) {
            return Err(ImageError::Outside(name, addr, size));
        }
        if addr == flash.origin {
            vectors = s.data().ok().map(<[u8]>::to_vec);
        }
        fp.sections.push((name, addr, size));
    }
    let vectors = vectors.ok_or(ImageError::NoVectorTable(flash.origin))?;
    let word = |i: usize| {
        vectors
            .get(4 * i..4 * i + 4)
            .map(|b| u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])))
    };
    let (Some(sp), Some(reset)) = (word(0), word(1)) else {
        return Err(ImageError::NoVectorTable(flash.origin));
    };
    fp.initial_sp = sp;
    fp.reset = reset;
    // Full descending stack: SP may equal the end of RAM, never its origin.
    if !(sp > ram.origin && sp <= ram.end() && sp % 8 == 0) {
        return Err(ImageError::StackPointer(sp));
    }
    if reset & 1 == 0 || !flash.contains(reset & !1) {
        return Err(ImageError::ResetVector(reset));
    }
    Ok(fp)
}

/// A data symbol of the image (a static).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Static {
    /// Its path, demangled without the hash (`nucleo_rig::robust_slots::VAR`).
    pub name: String,
    /// The output section it lies in.
    pub section: String,
    /// First address.
    pub address: u64,
    /// Size in bytes.
    pub size: u64,
}

/// Every static of at least `min_size` bytes, largest first.
pub fn large_statics(elf: &[u8], min_size: u64) -> Result<Vec<Static>, ImageError> {
    let file = object::File::parse(elf).map_err(|e| ImageError::Parse(e.to_string()))?;
    let mut out = Vec::new();
    for sym in file.symbols() {
        if sym.kind() != SymbolKind::Data || sym.size() < min_size {
            continue;
        }
        let section = sym
            .section_index()
            .and_then(|i| file.section_by_index(i).ok())
            .and_then(|s| s.name().ok().map(str::to_string))
            .unwrap_or_else(|| "?".into());
        out.push(Static {
            name: demangle(sym.name().unwrap_or("?")),
            section,
            address: sym.address(),
            size: sym.size(),
        });
    }
    out.sort_by(|a, b| b.size.cmp(&a.size).then(a.address.cmp(&b.address)));
    Ok(out)
}

/// A legacy-mangled Rust path (`_ZN3foo3bar17h0123456789abcdefE`) as
/// `foo::bar`, without the hash; anything else unchanged.
fn demangle(name: &str) -> String {
    let Some(mut rest) = name.strip_prefix("_ZN") else {
        return name.to_string();
    };
    let mut parts = Vec::new();
    while let Some(end) = rest.find(|c: char| !c.is_ascii_digit()) {
        if end == 0 {
            break;
        }
        let Ok(len) = rest[..end].parse::<usize>() else {
            break;
        };
        let Some(part) = rest.get(end..end + len) else {
            return name.to_string();
        };
        let is_hash = part.len() == 17
            && part.starts_with('h')
            && part[1..].chars().all(|c| c.is_ascii_hexdigit());
        if !is_hash {
            let part = part
                .strip_prefix('_')
                .filter(|p| p.starts_with('$'))
                .unwrap_or(part);
            let mut text = part.replace("..", "::");
            for (code, c) in [
                ("$LT$", "<"),
                ("$GT$", ">"),
                ("$u7b$", "{"),
                ("$u7d$", "}"),
                ("$C$", ","),
                ("$RF$", "&"),
                ("$BP$", "*"),
                ("$u20$", " "),
                ("$LP$", "("),
                ("$RP$", ")"),
            ] {
                text = text.replace(code, c);
            }
            parts.push(text);
        }
        rest = &rest[end + len..];
    }
    if parts.is_empty() || rest != "E" {
        name.to_string()
    } else {
        parts.join("::")
    }
}

fn is_alloc(s: &object::Section<'_, '_>) -> bool {
    match s.flags() {
        SectionFlags::Elf { sh_flags } => sh_flags & u64::from(object::elf::SHF_ALLOC) != 0,
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::demangle;

    #[test]
    fn demangles_legacy_paths_without_the_hash() {
        assert_eq!(
            demangle("_ZN10nucleo_rig12robust_slots3VAR17h0123456789abcdefE"),
            "nucleo_rig::robust_slots::VAR"
        );
        assert_eq!(
            demangle("_ZN10nucleo_rig12robust_slots28_$u7b$$u7b$closure$u7d$$u7d$3VAR17h0123456789abcdefE"),
            "nucleo_rig::robust_slots::{{closure}}::VAR"
        );
        assert_eq!(demangle("SAMPLE_METER"), "SAMPLE_METER");
        assert_eq!(demangle("_ZN3foo"), "_ZN3foo");
    }
}
