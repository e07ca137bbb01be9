//! Noise studies on the paper's plant: a recorded experiment (held u,
//! noise-free sampled y), white noise at a given SNR, truth-free signal
//! scales, and a plain run loop for any [`Estimator`].
//!
//! The SNR is relative to the RMS of the noise-free y over the whole record,
//! the definition the Cramér–Rao bound uses (`beamest::crlb`).

use beamest::estimator::Estimator;
use beamest::excitation::SquareWave;
use beamest::filter_bank::{FilterConfig, SignalScales};
use beamest::modal::modal_from_tf;
use beamest::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};
use beamest::rig::ModalPlant;
use beamest::rig::{noise_sd_for_snr, GaussianNoise};
use beamest::Real;

/// Sample period of the studies (the paper's 0.1 ms).
pub const TS_S: f64 = 1e-4;

/// One experiment on the paper's plant: the held input and the noise-free
/// sampled output.
#[derive(Debug, Clone)]
pub struct Record {
    /// Held input u_k (0.1·square(7 Hz)).
    pub u: Vec<f64>,
    /// Noise-free y(t_k).
    pub y: Vec<f64>,
}

impl Record {
    /// The paper's plant (Table III ω, ζ; eq. 46 numerator) driven by
    /// 0.1·square(7 Hz) for `seconds`.
    pub fn paper(seconds: f64) -> Self {
        let n = (seconds / TS_S).round() as usize;
        let mut plant =
            ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS_S)
                .expect("the paper's plant is valid");
        let mut sq = SquareWave::<f64>::paper();
        let mut u = Vec::with_capacity(n);
        let mut y = Vec::with_capacity(n);
        for _ in 0..n {
            let uk = sq.next_sample();
            u.push(uk);
            y.push(plant.sample(uk));
        }
        Self { u, y }
    }

    /// RMS of the noise-free output over the record.
    pub fn rms_y(&self) -> f64 {
        (self.y.iter().map(|v| v * v).sum::<f64>() / self.y.len().max(1) as f64).sqrt()
    }

    /// The output with white Gaussian noise at `snr_db` (relative to
    /// [`Self::rms_y`]), or the noise-free output for `None`.
    pub fn noisy_y(&self, snr_db: Option<f64>, seed: u64) -> Vec<f64> {
        let Some(snr) = snr_db else {
            return self.y.clone();
        };
        let sd = noise_sd_for_snr(self.rms_y(), snr);
        let mut noise = GaussianNoise::<f64>::new(sd, seed).expect("finite SNR");
        self.y.iter().map(|&y| y + noise.sample()).collect()
    }
}

/// Truth-free signal scales: U0, Y0 = RMS of u and y over the first
/// `window_s` seconds of the data the estimator sees.
pub fn startup_scales(u: &[f64], y: &[f64], window_s: f64) -> SignalScales {
    let n = ((window_s / TS_S).round() as usize).clamp(1, u.len().min(y.len()).max(1));
    let rms = |v: &[f64]| (v[..n].iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt();
    SignalScales {
        u_scale: rms(u),
        y_scale: rms(y),
    }
}

/// The filter configuration of the studies: λ = 100 rad/s (the paper's
/// choice), Ts = 0.1 ms, start-up scales over the first 0.5 s.
pub fn study_filter(u: &[f64], y: &[f64]) -> FilterConfig {
    FilterConfig {
        ts_s: TS_S,
        lambda_rad_s: 100.0,
        scales: startup_scales(u, y, 0.5),
        ..FilterConfig::default()
    }
}

/// Relative errors of ω1, ω2, ζ1, ζ2 (NaN where recovery failed).
pub type Errors = [f64; 4];

/// Feed the whole record (in working precision) and return the signed
/// relative errors of ω1, ω2, ζ1, ζ2 at the end. `observe` sees the
/// estimator after every `every` samples (time in s).
pub fn run<T: Real, const NP: usize>(
    est: &mut dyn Estimator<T, NP>,
    u: &[f64],
    y: &[f64],
    every: usize,
    observe: &mut dyn FnMut(f64, &dyn Estimator<T, NP>),
) -> Errors {
    for (k, (&uk, &yk)) in u.iter().zip(y).enumerate() {
        est.step(T::from_f64(uk), T::from_f64(yk));
        if every > 0 && (k + 1) % every == 0 {
            observe((k + 1) as f64 * TS_S, &*est);
        }
    }
    errors(&*est)
}

/// Signed relative errors of ω1, ω2, ζ1, ζ2 of a 2-mode estimate.
pub fn errors<T: Real, const NP: usize>(est: &dyn Estimator<T, NP>) -> Errors {
    let w = [T::from_f64(-2.0), T::from_f64(2.0)];
    match modal_from_tf(&est.transfer_function(), &w) {
        Ok(m) if m.modes == 2 => [
            m.omega_rad_s[0].to_f64() / PAPER_OMEGA[0] - 1.0,
            m.omega_rad_s[1].to_f64() / PAPER_OMEGA[1] - 1.0,
            m.zeta[0].to_f64() / PAPER_ZETA[0] - 1.0,
            m.zeta[1].to_f64() / PAPER_ZETA[1] - 1.0,
        ],
        _ => [f64::NAN; 4],
    }
}

/// Root mean square over runs, per parameter.
pub fn rms(runs: &[Errors]) -> Errors {
    let mut out = [0.0; 4];
    for (i, o) in out.iter_mut().enumerate() {
        *o = (runs.iter().map(|e| e[i] * e[i]).sum::<f64>() / runs.len().max(1) as f64).sqrt();
    }
    out
}

/// Parameters of the transfer-function model set in the modal form of
/// `beamest::crlb` (2 modes): ω1, ω2, ζ1, ζ2, α1, α2, β (β1 = β, β2 = −β).
pub type TfParams = [f64; 7];

/// The paper's plant in that parameterization.
pub fn paper_tf_params() -> TfParams {
    let acc = beamest::crlb::FisherAccumulator::from_tf(
        &beamest::model::paper_plant_tf(),
        &[-2.0, 2.0],
        TS_S,
    )
    .expect("the paper's plant is valid");
    let m = acc.model();
    [
        m.omega_rad_s[0],
        m.omega_rad_s[1],
        m.zeta[0],
        m.zeta[1],
        m.alpha[0],
        m.alpha[1],
        m.beta[0],
    ]
}

/// Maximum-likelihood (output-error) fit of the 7-parameter model to a
/// record by Gauss–Newton, started at `start`, `iterations` steps. The
/// sensitivities are the exact ones of `beamest::crlb::sensitivity`; the
/// plant is assumed at rest at the first sample (as in the simulations).
/// Returns the estimate, or `None` if a step fails.
pub fn fit_output_error(
    u: &[f64],
    y: &[f64],
    start: &TfParams,
    iterations: usize,
) -> Option<TfParams> {
    use beamest::crlb::{ModalOutputModel, OutputSensitivity};
    let mut p = *start;
    for _ in 0..iterations {
        let model =
            ModalOutputModel::new(&[p[0], p[1]], &[p[2], p[3]], &[p[4], p[5]], &[p[6], -p[6]])
                .ok()?;
        let mut sens = OutputSensitivity::new(&model, TS_S).ok()?;
        let mut jtj = [[0.0f64; 7]; 7];
        let mut jtr = [0.0f64; 7];
        for (&uk, &yk) in u.iter().zip(y) {
            let s = sens.push(uk);
            let j = [
                s.d_omega[0],
                s.d_omega[1],
                s.d_zeta[0],
                s.d_zeta[1],
                s.eta[0],
                s.eta[1],
                s.eta_dot[0] - s.eta_dot[1],
            ];
            let r = yk - s.y;
            for a in 0..7 {
                jtr[a] += j[a] * r;
                for b in a..7 {
                    jtj[a][b] += j[a] * j[b];
                }
            }
        }
        for a in 0..7 {
            for b in 0..a {
                jtj[a][b] = jtj[b][a];
            }
        }
        // Equilibrate, then solve (cond of the raw JᵀJ is large).
        let d: Vec<f64> = (0..7).map(|i| jtj[i][i].sqrt()).collect();
        let mut m = [[0.0f64; 7]; 7];
        let mut rhs = [0.0f64; 7];
        for a in 0..7 {
            for b in 0..7 {
                m[a][b] = jtj[a][b] / (d[a] * d[b]);
            }
            rhs[a] = jtr[a] / d[a];
        }
        let x = cholesky_solve(m, rhs)?;
        for a in 0..7 {
            p[a] += x[a] / d[a];
        }
    }
    Some(p)
}

/// Solve the symmetric positive definite system m·x = b by Cholesky
/// (the equilibrated Gauss–Newton normal equations); `None` if m is not
/// positive definite in f64.
fn cholesky_solve<const N: usize>(mut m: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    for j in 0..N {
        let mut d = m[j][j];
        for k in 0..j {
            d -= m[j][k] * m[j][k];
        }
        if !(d > 0.0) {
            return None;
        }
        let d = d.sqrt();
        m[j][j] = d;
        for i in j + 1..N {
            let mut v = m[i][j];
            for k in 0..j {
                v -= m[i][k] * m[j][k];
            }
            m[i][j] = v / d;
        }
    }
    // Forward (L·z = b), then backward (Lᵀ·x = z).
    for i in 0..N {
        for k in 0..i {
            b[i] -= m[i][k] * b[k];
        }
        b[i] /= m[i][i];
    }
    for i in (0..N).rev() {
        for k in i + 1..N {
            b[i] -= m[k][i] * b[k];
        }
        b[i] /= m[i][i];
    }
    Some(b)
}
