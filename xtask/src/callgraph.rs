//! The static call graph of an interrupt handler, from the image's
//! disassembly (`llvm-objdump -d`), to check what the sample path can
//! reach: no panic, no software floating point (issue 6: "the interrupt
//! path has no unwrap, expect, panic! or indexing that can fail").
//!
//! Every direct branch to another function (`bl`, `b`, `b.w`, conditional
//! branches, `cbz`/`cbnz`) is an edge; an indirect branch (`blx rN`, `bx rN`
//! other than `bx lr`) inside the graph makes the graph incomplete, which is
//! reported as a failure rather than guessed around.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::Path;
use std::process::Command;

/// Functions of a disassembly: name → (direct callees, has an indirect
/// branch).
#[derive(Debug, Default)]
pub struct CallGraph {
    funcs: BTreeMap<String, (BTreeSet<String>, bool)>,
    /// Stack bytes each function reserves by immediate `sub sp` (its frame
    /// below the saved registers), and whether it also moves `sp` by a
    /// register (a frame of unknown size).
    frames: BTreeMap<String, (u64, bool)>,
}

/// What a reachable function must not be.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Finding {
    /// A panic entry point (`core::panicking::*`, `rust_begin_unwind`…).
    Panic(String),
    /// A software floating-point routine (`__aeabi_d*`, `__aeabi_f*`,
    /// integer ↔ float conversions).
    SoftFloat(String),
    /// An indirect branch in this function: the graph below it is unknown.
    Indirect(String),
    /// The root symbol is not in the image.
    NoRoot(String),
}

impl fmt::Display for Finding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Finding::Panic(s) => write!(f, "reaches a panic: {s}"),
            Finding::SoftFloat(s) => write!(f, "reaches software floating point: {s}"),
            Finding::Indirect(s) => write!(f, "indirect branch in {s}: graph incomplete"),
            Finding::NoRoot(s) => write!(f, "no function `{s}` in the image"),
        }
    }
}

const CONDITIONS: [&str; 16] = [
    "eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le",
];

fn is_branch(mnemonic: &str) -> bool {
    let m = mnemonic
        .strip_suffix(".w")
        .or_else(|| mnemonic.strip_suffix(".n"))
        .unwrap_or(mnemonic);
    matches!(m, "b" | "bl" | "cbz" | "cbnz")
        || (m.len() == 3 && m.starts_with('b') && CONDITIONS.contains(&&m[1..]))
}

/// `<name+0x10>` → `name`.
fn target(operands: &str) -> Option<&str> {
    let start = operands.find('<')? + 1;
    let end = start + operands[start..].find('>')?;
    let sym = &operands[start..end];
    Some(sym.split('+').next().unwrap_or(sym))
}

impl CallGraph {
    /// Parse `llvm-objdump -d --demangle` output.
    pub fn parse(disassembly: &str) -> Self {
        let mut g = CallGraph::default();
        let mut current: Option<String> = None;
        for line in disassembly.lines() {
            if let Some(name) = line
                .strip_suffix(">:")
                .and_then(|l| l.split_once(" <"))
                .filter(|(addr, _)| addr.chars().all(|c| c.is_ascii_hexdigit()))
                .map(|(_, name)| name.to_string())
            {
                // `$t`, `$d`, `$a`: ARM mapping symbols (code or data after
                // a literal pool or jump table) inside the current function.
                if name.starts_with('$') && current.is_some() {
                    continue;
                }
                g.funcs.entry(name.clone()).or_default();
                current = Some(name);
                continue;
            }
            let Some(cur) = current.as_ref() else {
                continue;
            };
            // "  addr: bytes \t mnemonic \t operands"
            let mut fields = line.split('\t').skip(1);
            let (Some(mnemonic), operands) = (fields.next(), fields.next().unwrap_or("")) else {
                continue;
            };
            let mnemonic = mnemonic.trim();
            if let Some(frame) = sp_subtraction(mnemonic, operands) {
                let f = g.frames.entry(cur.clone()).or_default();
                match frame {
                    Some(bytes) => f.0 += bytes,
                    None => f.1 = true,
                }
            }
            let entry = g.funcs.entry(cur.clone()).or_default();
            if is_branch(mnemonic) {
                // A branch to a mapping symbol stays inside the function.
                if let Some(t) =
                    target(operands).filter(|t| *t != cur.as_str() && !t.starts_with('$'))
                {
                    entry.0.insert(t.to_string());
                }
            } else if (mnemonic == "blx" || mnemonic == "bx") && operands.trim() != "lr" {
                entry.1 = true;
            }
        }
        g
    }

    /// The function with the largest immediate stack frame, and its bytes.
    pub fn largest_frame(&self) -> Option<(&str, u64)> {
        self.frames
            .iter()
            .map(|(name, (bytes, _))| (name.as_str(), *bytes))
            .max_by_key(|&(_, bytes)| bytes)
    }

    /// Functions that move `sp` by a register (frames of unknown size).
    pub fn dynamic_frames(&self) -> Vec<&str> {
        self.frames
            .iter()
            .filter(|(_, (_, dynamic))| *dynamic)
            .map(|(name, _)| name.as_str())
            .collect()
    }

    /// Everything reachable from `root`, and what is wrong with it.
    pub fn check(&self, root: &str) -> (BTreeSet<String>, Vec<Finding>) {
        let mut seen = BTreeSet::new();
        let mut findings = Vec::new();
        if !self.funcs.contains_key(root) {
            findings.push(Finding::NoRoot(root.to_string()));
            return (seen, findings);
        }
        let mut stack = vec![root.to_string()];
        while let Some(f) = stack.pop() {
            if !seen.insert(f.clone()) {
                continue;
            }
            if f.contains("panic") || f.contains("rust_begin_unwind") {
                findings.push(Finding::Panic(f.clone()));
            }
            if is_soft_float(&f) {
                findings.push(Finding::SoftFloat(f.clone()));
            }
            if let Some((callees, indirect)) = self.funcs.get(&f) {
                if *indirect {
                    findings.push(Finding::Indirect(f.clone()));
                }
                stack.extend(callees.iter().cloned());
            }
        }
        (seen, findings)
    }
}

/// `sub sp, #N` / `sub.w sp, sp, #N` / `subw sp, sp, #N`: `Some(Some(N))`;
/// the same by a register: `Some(None)`; anything else: `None`.
fn sp_subtraction(mnemonic: &str, operands: &str) -> Option<Option<u64>> {
    if !matches!(mnemonic, "sub" | "sub.w" | "subw" | "subs") {
        return None;
    }
    let ops: Vec<&str> = operands
        .split('@')
        .next()
        .unwrap_or("")
        .split(',')
        .map(str::trim)
        .collect();
    let amount = match ops.as_slice() {
        ["sp", "sp", a] | ["sp", a] => *a,
        _ => return None,
    };
    Some(amount.strip_prefix('#').and_then(|n| {
        n.strip_prefix("0x")
            .map_or_else(|| n.parse().ok(), |h| u64::from_str_radix(h, 16).ok())
    }))
}

/// `__aeabi_dadd`, `__aeabi_fmul`, `__aeabi_l2d`, `__aeabi_f2d`… (run-time
/// ABI floating-point helpers), not the integer or memory ones.
fn is_soft_float(name: &str) -> bool {
    let Some(rest) = name.strip_prefix("__aeabi_") else {
        return false;
    };
    rest.starts_with('d') || rest.starts_with('f') || rest.contains("2d") || rest.contains("2f")
}

/// Disassemble `elf` with `llvm-objdump` (the rustup `llvm-tools`
/// component's, or one on PATH).
pub fn disassemble(elf: &Path, mcpu: &str) -> Result<String, String> {
    let sysroot = Command::new("rustc")
        .args(["--print", "sysroot"])
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string());
    let mut candidates = Vec::new();
    if let Some(root) = sysroot {
        let lib = Path::new(&root).join("lib/rustlib");
        if let Ok(entries) = std::fs::read_dir(&lib) {
            for e in entries.flatten() {
                candidates.push(e.path().join("bin/llvm-objdump"));
            }
        }
    }
    candidates.push("llvm-objdump".into());
    for tool in candidates {
        let out = Command::new(&tool)
            .args(["-d", "--demangle", &format!("--mcpu={mcpu}")])
            .arg(elf)
            .output();
        if let Ok(out) = out {
            if out.status.success() {
                return String::from_utf8(out.stdout).map_err(|e| e.to_string());
            }
        }
    }
    Err("llvm-objdump not found: rustup component add llvm-tools".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "\
08000298 <ISR>:
 8000298: f01b fc6a    \tbl\t0x801bb70 <work> @ imm = #0x1b8d4
 800029c: d3fa         \tblo\t0x8000294 <ISR+0x4>
 80002a0: f000 b800    \tb.w\t0x80002a4 <tail::h1> @ imm = #0x0
 80002a4: 4770         \tbx\tlr

080002a4 <tail::h1>:
 80002a4: 2800         \tcmp\tr0, #0x0
 80002a6: d100         \tbne\t0x80002aa <core::panicking::panic_bounds_check>
 80002a8: 4770         \tbx\tlr

0801bb70 <work>:
 801bb70: f7ff fffe    \tbl\t0x8000000 <__aeabi_dmul>
 801bb74: f7ff fffe    \tbl\t0x8000000 <__aeabi_uldivmod>
 801bb78: 4770         \tbx\tlr

080002a6 <$d>:
 80002a6: 01 00        \t.short\t0x0001

080002a8 <$t>:
 80002a8: f000 b800    \tb.w\t0x80002aa <$t+0x2>

080002aa <core::panicking::panic_bounds_check>:
 80002aa: 4780         \tblx\tr0

08000000 <__aeabi_dmul>:
 8000000: 4770         \tbx\tlr

08000010 <__aeabi_uldivmod>:
 8000010: 4770         \tbx\tlr

08000020 <clean>:
 8000020: f7ff fffe    \tbl\t0x8000010 <__aeabi_uldivmod>
 8000024: 4770         \tbx\tlr

08000030 <framed>:
 8000030: b0ff         \tsub\tsp, #0x1fc
 8000032: f5ad 5d00    \tsub.w\tsp, sp, #8192
 8000036: f6ad 0d10    \tsubw\tsp, sp, #2064
 800003a: ebad 0d00    \tsub.w\tsp, sp, r0
 800003e: 3801         \tsubs\tr0, #0x1
";

    #[test]
    fn finds_calls_tail_calls_and_conditional_branches() {
        let g = CallGraph::parse(TEXT);
        let (seen, findings) = g.check("ISR");
        let names: Vec<&str> = seen.iter().map(String::as_str).collect();
        assert_eq!(
            names,
            [
                "ISR",
                "__aeabi_dmul",
                "__aeabi_uldivmod",
                "core::panicking::panic_bounds_check",
                "tail::h1",
                "work"
            ]
        );
        assert!(findings.contains(&Finding::SoftFloat("__aeabi_dmul".into())));
        assert!(findings.contains(&Finding::Panic(
            "core::panicking::panic_bounds_check".into()
        )));
        assert!(findings.contains(&Finding::Indirect(
            "core::panicking::panic_bounds_check".into()
        )));
        assert_eq!(findings.len(), 3);
    }

    #[test]
    fn stack_frames() {
        let g = CallGraph::parse(TEXT);
        assert_eq!(g.largest_frame(), Some(("framed", 0x1fc + 8192 + 2064)));
        assert_eq!(g.dynamic_frames(), vec!["framed"]);
    }

    #[test]
    fn clean_graph_and_missing_root() {
        let g = CallGraph::parse(TEXT);
        let (seen, findings) = g.check("clean");
        assert_eq!(seen.len(), 2);
        assert!(findings.is_empty());
        assert!(!is_soft_float("__aeabi_uldivmod") && !is_soft_float("__aeabi_memcpy8"));
        assert!(is_soft_float("__aeabi_l2d") && is_soft_float("__aeabi_f2d"));
        let (_, findings) = g.check("EXTI3");
        assert_eq!(findings, vec![Finding::NoRoot("EXTI3".into())]);
    }
}
