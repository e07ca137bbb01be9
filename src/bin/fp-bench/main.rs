//! What single and double precision cost on a Cortex-M4F and a Cortex-M7:
//! the 2-mode estimator step in `f32` and in `f64`, counted in executed
//! instructions under QEMU (`cargo xtask fp-bench`).
//!
//! The same image source runs on two emulated boards that share the
//! QEMU `mps2-an386` memory map, CMSDK peripherals and 25 MHz SysTick
//! (QEMU `hw/arm/mps2.c`: AN385/AN386/AN500 map ZBT SSRAM1 at 0 and
//! SSRAM2&3 at 0x2000_0000, UART0 at 0x4000_4000, the same IRQ lines):
//!
//! * `mps2-an386`, Cortex-M4F, built for the generic `thumbv7em-none-eabihf`
//!   (single-precision FPU only: `f64` is software);
//! * `mps2-an500`, Cortex-M7, built with `-C target-cpu=cortex-m7`
//!   (FPv5-D16: `f32` and `f64` in hardware, as on the STM32H743).
//!
//! For each precision: the paper's simulated plant (Wang, Costa-Castelló,
//! Na et al., *Modelling and Adaptive Parameter Estimation for a
//! Piezoelectric Cantilever Beam*, Section IV.A, eq. 46, simulated in
//! `f64`) driven by the paper's square wave, Y0 measured as the RMS of y
//! over the first 0.1 s (as the firmware does), then 5 s of estimator
//! steps, each timed with SysTick (one tick = 40 instructions under
//! `-icount shift=0`, sub-tick resolution by the dither of
//! [`cycles::dither`]); one modal recovery (eqs. 30–32) timed at the end.
//! The simulated truth is read only to report the final errors.
//!
//! Output (semihosting): one `fp_bench:` line per precision with its
//! figures and its final estimate (`omega=ω1,ω2 zeta=ζ1,ζ2`, or
//! `omega=none` if none was recovered), then exit 0. The image does not
//! read the simulated truth: `cargo xtask fp-bench` judges the estimates
//! (both precisions within 1e-3 of the paper's ω, ζ).

#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use beamest::board::qemu::cycles::{self, SpanSum};
use beamest::board::qemu::{self as board};
use beamest::estimator::{Adaptive2, AdaptiveConfig, Estimator};
use beamest::excitation::SquareWave;
use beamest::filter_bank::{FilterConfig, SignalScales};
use beamest::modal::modal_from_tf;
use beamest::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};
use beamest::rig::{ModalPlant, Rig};
use beamest::Real;
use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use panic_semihosting as _;

/// Sample period (the paper's Ts), s.
const TS_S: f64 = 1e-4;
/// Start-up window that measures Y0, samples (0.1 s).
const STARTUP_SAMPLES: u32 = 1_000;
/// Timed estimator steps after the start-up window (5 s).
const RUN_SAMPLES: u32 = 50_000;
/// Filter pole λ, rad/s (the paper's Section IV.A).
const LAMBDA_RAD_S: f64 = 100.0;
/// U0: the excitation amplitude, known to the user (V).
const U_SCALE: f64 = 0.1;
/// Output weights c_i of the paper's two-mode beam (eq. 24), for b̄.
const OUTPUT_WEIGHT: [f64; 2] = [-2.0, 2.0];

/// One precision's figures.
struct Figures {
    step: SpanSum,
    recovery_instructions: f32,
    /// The final ω1, ω2, ζ1, ζ2 (`None`: no modes recovered).
    estimate: Option<[f64; 4]>,
}

#[entry]
fn main() -> ! {
    let Some(cp) = cortex_m::Peripherals::take() else {
        fail("core peripherals already taken")
    };
    cycles::start_systick(cp.SYST);
    let cal = cycles::calibrate();
    if !cal.is_as_expected() {
        hprintln!(
            "error: SysTick measured {} instructions per tick, expected {} \
             (run QEMU with -icount shift=0,sleep=off)",
            cal.instructions_per_tick(),
            cycles::EXPECTED_INSTRUCTIONS_PER_TICK
        );
        board::exit(false);
    }
    let ipt = cal.instructions_per_tick();
    for result in [run::<f32>(), run::<f64>()] {
        let Ok((name, f)) = result else {
            fail("plant or estimator construction")
        };
        hprintln!(
            "fp_bench: {} step_instructions={} (max {}) recovery_instructions={} steps={}",
            name,
            libm::roundf(f.step.mean_instructions(ipt)) as u32,
            (f.step.max_ticks as f32 * ipt) as u32,
            libm::roundf(f.recovery_instructions) as u32,
            f.step.count
        );
        match f.estimate {
            Some([w1, w2, z1, z2]) => hprintln!(
                "fp_bench: {} omega={:.9e},{:.9e} zeta={:.9e},{:.9e}",
                name,
                w1,
                w2,
                z1,
                z2
            ),
            None => hprintln!("fp_bench: {} omega=none", name),
        }
    }
    board::exit(true)
}

/// The start-up window, then [`RUN_SAMPLES`] timed steps in precision `T`.
fn run<T: Real>() -> Result<(&'static str, Figures), ()> {
    let plant = ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS_S)
        .map_err(|_| ())?;
    let mut rig = Rig::new(plant, SquareWave::<f64>::paper());

    let mut square_sum = 0.0_f64;
    for _ in 0..STARTUP_SAMPLES {
        let s = rig.tick();
        square_sum += s.y * s.y;
    }
    let y_rms = libm::sqrt(square_sum / f64::from(STARTUP_SAMPLES));
    let filter = FilterConfig {
        ts_s: TS_S,
        lambda_rad_s: LAMBDA_RAD_S,
        scales: SignalScales {
            u_scale: U_SCALE,
            y_scale: y_rms,
        },
        ..FilterConfig::default()
    };
    let mut est = Adaptive2::<T>::new(&filter, &AdaptiveConfig::default()).map_err(|_| ())?;
    // The beam already moves: hold the law while the filters settle (one
    // invalid sample arms the estimator's input quarantine, `QUARANTINE_TIME_CONSTANTS`/λ).
    let nan = T::from_f64(f64::NAN);
    est.step(nan, nan);

    let mut step = SpanSum::default();
    for k in 0..RUN_SAMPLES {
        let s = rig.tick();
        let (u, y) = (T::from_f64(s.u), T::from_f64(s.y));
        cycles::dither(k);
        let t0 = cycles::now();
        timed_step(&mut est, u, y);
        step.add(t0, cycles::now());
    }

    let weight = OUTPUT_WEIGHT.map(T::from_f64);
    let t0 = cycles::now();
    let modes = modal_from_tf(&est.transfer_function(), &weight);
    let recovery_ticks = cycles::ticks_between(t0, cycles::now());

    let estimate = modes.ok().filter(|m| m.modes == 2).map(|m| {
        [
            m.omega_rad_s[0].to_f64(),
            m.omega_rad_s[1].to_f64(),
            m.zeta[0].to_f64(),
            m.zeta[1].to_f64(),
        ]
    });
    Ok((
        T::NAME,
        Figures {
            step,
            recovery_instructions: recovery_ticks as f32
                * cycles::EXPECTED_INSTRUCTIONS_PER_TICK as f32,
            estimate,
        },
    ))
}

/// The estimator step, out of line so it can be found in the disassembly
/// (soft-float check: `llvm-objdump -d` for `__aeabi_d*` calls).
#[inline(never)]
fn timed_step<T: Real>(est: &mut Adaptive2<T>, u: T, y: T) {
    est.step(u, y);
}

/// Log and exit with failure.
fn fail(what: &str) -> ! {
    hprintln!("error: {}", what);
    board::exit(false)
}
