//! Firmware link setup, per board feature (DESIGN: features, not crates,
//! pick the board).
//!
//! Host builds (no board feature) do nothing here. With a board feature this
//! script
//! * refuses a second board or a non-Cortex-M target with a message that
//!   says what to run instead;
//! * copies that board's memory map (`src/board/nucleo/memory.x` for the
//!   NUCLEO-H743ZI2, `src/board/qemu/memory.x` for QEMU `mps2-an386`) to
//!   `$OUT_DIR/board-memory.x` and puts `$OUT_DIR` on the linker search
//!   path, where the top-level `memory.x` (which cortex-m-rt's `link.x`
//!   includes) includes it. The map cannot simply be a `memory.x` on the
//!   search path: the linker resolves `INCLUDE` in its current directory
//!   (the workspace root) first, so the top-level file always wins;
//!   flip-link follows the same `INCLUDE` chain to find the RAM region;
//! * for the QEMU board, also `device.x` (the weak aliases of the device
//!   interrupt handlers that cortex-m-rt's `device` feature includes);
//! * sets `cfg(beamest_cortex_m7)` when the target's rustflags hold
//!   `-C target-cpu=cortex-m7` (the reference board's binary refuses to
//!   build without the M7's double-precision FPU);
//!
//!
//! and for every build, board or not, the fused multiply-add routes of
//! `src/scalar/fma.rs`, set only where `asm!` may name the FPU's registers
//! (stable Rust 1.95 exposes no ARM FPU feature to `cfg`, and its `asm!`
//! accepts the `sreg` class only with its `vfp2` feature, which the
//! generic `thumbv7em-none-eabihf` does not report although its FPv4-SP
//! has `VFMA.F32`):
//! * `cfg(beamest_fma_f32)` on `thumbv7em-*-eabihf` with
//!   `-C target-cpu=cortex-m7`, or with `-C target-feature=+vfp2,-fp64`
//!   (what `cargo xtask` passes for the Cortex-M4F images: `vfp2` lets
//!   `asm!` use the S registers, `-fp64` keeps `f64` in software as the
//!   M4F needs);
//! * `cfg(beamest_fma_f64)` with `-C target-cpu=cortex-m7` (FPv5-D16:
//!   `VFMA.F64`; the M4F has no double-precision FPU);
//! * passes the link scripts to the firmware binaries only (`-Tlink.x`,
//!   `-Tdefmt.x` where defmt is linked, `--nmagic`), so the library's unit
//!   tests and host tools never see them.

use std::env;
use std::fs;
use std::path::PathBuf;

/// One firmware board: its feature, memory map and optional device vector.
struct Board {
    feature_env: &'static str,
    name: &'static str,
    memory_x: &'static str,
    device_x: Option<&'static str>,
    defmt: bool,
}

const BOARDS: [Board; 2] = [
    Board {
        feature_env: "CARGO_FEATURE_BOARD_QEMU",
        name: "board-qemu",
        memory_x: "src/board/qemu/memory.x",
        device_x: Some("src/board/qemu/device.x"),
        defmt: false,
    },
    Board {
        feature_env: "CARGO_FEATURE_BOARD_NUCLEO",
        name: "board-nucleo",
        memory_x: "src/board/nucleo/memory.x",
        device_x: None,
        defmt: true,
    },
];

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=memory.x");
    for b in &BOARDS {
        println!("cargo:rerun-if-changed={}", b.memory_x);
        if let Some(d) = b.device_x {
            println!("cargo:rerun-if-changed={d}");
        }
    }

    // Set below when the firmware is built for the Cortex-M7 (the
    // reference board's binary refuses to build without it).
    println!("cargo::rustc-check-cfg=cfg(beamest_cortex_m7)");
    println!("cargo::rustc-check-cfg=cfg(beamest_fma_f32)");
    println!("cargo::rustc-check-cfg=cfg(beamest_fma_f64)");

    let target = env::var("TARGET").unwrap_or_default();
    let codegen = codegen_flags();
    let cortex_m7 = codegen.iter().any(|f| f == "target-cpu=cortex-m7");
    let sreg_allowed = cortex_m7
        || codegen.iter().any(|f| {
            f.strip_prefix("target-feature=")
                .is_some_and(|list| list.split(',').any(|x| x == "+vfp2"))
        });
    if target.starts_with("thumbv7em-") && target.ends_with("eabihf") && sreg_allowed {
        println!("cargo::rustc-cfg=beamest_fma_f32");
        if cortex_m7 {
            println!("cargo::rustc-cfg=beamest_fma_f64");
        }
    }

    let enabled: Vec<&Board> = BOARDS
        .iter()
        .filter(|b| env::var_os(b.feature_env).is_some())
        .collect();
    let board = match enabled.as_slice() {
        [] => return,
        [one] => *one,
        many => {
            let names: Vec<&str> = many.iter().map(|b| b.name).collect();
            panic!(
                "features {} select different boards: enable exactly one \
                 (`cargo xtask firmware` builds each board separately)",
                names.join(" and ")
            );
        }
    };

    if !target.starts_with("thumbv7em-") {
        panic!(
            "feature `{}` builds firmware for thumbv7em-none-eabihf, not `{target}`: \
             add `--target thumbv7em-none-eabihf`, or use `cargo xtask firmware` / \
             `cargo xtask qemu`",
            board.name
        );
    }

    if cortex_m7 {
        println!("cargo::rustc-cfg=beamest_cortex_m7");
    }

    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    copy(board.memory_x, &out.join("board-memory.x"));
    if let Some(d) = board.device_x {
        copy(d, &out.join("device.x"));
    }
    println!("cargo:rustc-link-search={}", out.display());

    // Link scripts for the firmware binaries only (the knurling app-template
    // passes the same flags through rustflags; here they depend on the board).
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    if board.defmt {
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    }
}

/// The values of the `-C` options in the target's rustflags (cargo passes
/// them to build scripts, 0x1F-separated; `-C x` and `-Cx` alike).
fn codegen_flags() -> Vec<String> {
    let rustflags = env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
    let mut flags = rustflags.split('\x1f').peekable();
    let mut out = Vec::new();
    while let Some(flag) = flags.next() {
        match flag.strip_prefix("-C") {
            Some("") => out.push(flags.next().unwrap_or_default().to_string()),
            Some(rest) => out.push(rest.to_string()),
            None => {}
        }
    }
    out
}

fn copy(from: &str, to: &PathBuf) {
    let text = fs::read(from).unwrap_or_else(|e| panic!("reading {from}: {e}"));
    fs::write(to, text).unwrap_or_else(|e| panic!("writing {}: {e}", to.display()));
}
