//! Board support, one folder per board, each behind its board feature
//! (`board-qemu`, `board-nucleo`) and built only for
//! `thumbv7em-none-eabihf`. This is the only layer that may use `unsafe`
//! (memory-mapped registers, the vector table, NVIC priorities); each
//! board module opts in with `#![allow(unsafe_code)]` and keeps it in tiny,
//! documented functions. The rest of the crate is `forbid(unsafe_code)`
//! in every build without a board feature and `deny(unsafe_code)` in
//! firmware builds.

#[cfg(feature = "board-qemu")]
pub mod qemu;

#[cfg(feature = "board-nucleo")]
pub mod nucleo;
