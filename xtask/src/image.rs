//! Size and sanity of a linked firmware image (ELF), against its board's
//! memory map.

use std::fmt;

use object::{Object, ObjectSection, SectionFlags, SectionKind};

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
    /// An allocated section lies outside both FLASH and RAM.
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
                write!(f, "section {n} ({a:#010x}, {s} B) outside FLASH and RAM")
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

/// Measure `elf` and check its vector table against `flash` and `ram`.
pub fn inspect(elf: &[u8], flash: &Region, ram: &Region) -> Result<Footprint, ImageError> {
    let file = object::File::parse(elf).map_err(|e| ImageError::Parse(e.to_string()))?;
    let mut fp = Footprint {
        flash: 0,
        ram: 0,
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

fn is_alloc(s: &object::Section<'_, '_>) -> bool {
    match s.flags() {
        SectionFlags::Elf { sh_flags } => sh_flags & u64::from(object::elf::SHF_ALLOC) != 0,
        _ => false,
    }
}
