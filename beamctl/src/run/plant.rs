//! Simulated beams: which plant, and its true parameters. (The rig itself —
//! plant, excitation and measurement noise — is `beamest::rig`.)

use beamest::model::{
    paper_plant_tf, ModalParams, TransferFunction, PAPER_B, PAPER_OMEGA, PAPER_ZETA,
};
use beamest::rig::{ModalPlant, PlantError};

/// The paper's b̄ (eq. 32 applied to eq. 46's b with Table III's ω, ζ),
/// rounded to 5 significant digits; the core's test
/// `modal::tests::paper_plant_eq46_numerator_gives_reference_bbar` derives
/// it.
pub const PAPER_BBAR: [f64; 2] = [9.6293, 16.1458];

/// Default third mode used when `--modes 3` is asked without `--omega`:
/// the Table I beam's third bending mode, ω3 = ω2·(β3/β2)² ≈ 687.4 rad/s,
/// with ζ3 = 0.05 and b̄3 = 20 (documented in docs/CLI.md).
pub const DEFAULT_MODE3: (f64, f64, f64) = (687.4, 0.05, 20.0);

/// Which simulated beam to run.
#[derive(Debug, Clone, PartialEq)]
pub enum PlantSpec {
    /// The paper's simulation plant: Table III ω, ζ and eq. 46's numerator.
    Paper,
    /// A modal model (eq. 23) with b̄ and output weights.
    Modal(ModalParams<f64>),
}

/// True parameters of a simulated beam.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Truth {
    /// ω, ζ, b̄ and output weights.
    pub modal: ModalParams<f64>,
    /// a, b of eq. 25–26.
    pub tf: TransferFunction<f64>,
}

impl PlantSpec {
    /// The documented default plant for `modes` modes: 2 → the paper's;
    /// 1 → its first mode; 3 → the paper's two modes plus [`DEFAULT_MODE3`].
    pub fn default_for_modes(modes: usize) -> Option<Self> {
        match modes {
            1 => ModalParams::new(&PAPER_OMEGA[..1], &PAPER_ZETA[..1], &PAPER_BBAR[..1], None)
                .map(Self::Modal),
            2 => Some(Self::Paper),
            3 => {
                let (w, z, b) = DEFAULT_MODE3;
                ModalParams::new(
                    &[PAPER_OMEGA[0], PAPER_OMEGA[1], w],
                    &[PAPER_ZETA[0], PAPER_ZETA[1], z],
                    &[PAPER_BBAR[0], PAPER_BBAR[1], b],
                    None,
                )
                .map(Self::Modal)
            }
            _ => None,
        }
    }

    /// Number of modes.
    pub fn modes(&self) -> usize {
        match self {
            Self::Paper => 2,
            Self::Modal(m) => m.modes,
        }
    }

    /// True ω, ζ, b̄ and transfer function.
    pub fn truth(&self) -> Truth {
        match self {
            Self::Paper => {
                let tf = paper_plant_tf();
                let mut modal =
                    ModalParams::new(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_BBAR, None).expect("static");
                // b̄ exactly as eq. 32 gives it from eq. 46 (PAPER_BBAR is rounded).
                if let Ok(m) = beamest::modal::modal_from_tf(&tf, &modal.output_weight[..2]) {
                    modal.bbar = m.bbar;
                }
                Truth { modal, tf }
            }
            Self::Modal(m) => Truth {
                modal: *m,
                tf: m.transfer_function(),
            },
        }
    }

    /// An exact discrete simulator of this beam.
    pub fn plant(&self, ts_s: f64) -> Result<ModalPlant<f64>, PlantError> {
        match self {
            Self::Paper => ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, ts_s),
            Self::Modal(m) => ModalPlant::from_modal(m, ts_s),
        }
    }
}
