//! Is a recovered modal estimate physical, and what to report when it is
//! not.
//!
//! A cantilever's modes are underdamped (0 < ζ < 1), have ω > 0 and are
//! distinct. An estimate outside that set — while the estimator is
//! converging, after a detected change, with too little excitation, or
//! when the root finder fails — is flagged by [`Validity`] (a bit set, so
//! every reason is kept) and never shown as if it were a beam.
//!
//! # What is reported
//! [`ModalHold`] keeps the last physically valid estimate: a valid
//! estimate is reported as is ([`Reported::current`]); an invalid or failed
//! one is reported as the last valid estimate, marked held, with the
//! current one's [`Validity`]; before the first valid estimate nothing is
//! reported (`None`). Reported ω, ζ, b̄ are therefore always finite and
//! physical — never NaN. (The serial link sends the current modes when
//! they are finite, flagged by PHYSICALLY_VALID, and none when they are
//! not: docs/PROTOCOL.md §9.3.)

use super::ModalError;
use crate::model::{ModalParams, MAX_MODES};
use crate::scalar::Real;

/// Why a modal estimate is not physical (empty = valid).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Validity(pub u8);

impl Validity {
    /// Valid.
    pub(crate) const VALID: Self = Self(0);
    /// Recovery failed (roots or gains; [`ModalError`]).
    pub const NOT_RECOVERED: Self = Self(1 << 0);
    /// Another number of modes than the model has.
    pub(crate) const MODE_COUNT: Self = Self(1 << 1);
    /// A value is NaN or infinite.
    pub(crate) const NON_FINITE: Self = Self(1 << 2);
    /// Some ω ≤ 0.
    pub(crate) const OMEGA_NOT_POSITIVE: Self = Self(1 << 3);
    /// Some ζ ≤ 0 (unstable or undamped) or ζ ≥ 1 (overdamped: real poles).
    pub const ZETA_OUT_OF_RANGE: Self = Self(1 << 4);
    /// Two modes with the same ω (not strictly ascending).
    pub(crate) const NOT_DISTINCT: Self = Self(1 << 5);

    /// The flags of `m` for a model of `model_modes` modes.
    pub fn of<T: Real>(m: &ModalParams<T>, model_modes: usize) -> Self {
        let mut v = Self::VALID;
        if m.modes != model_modes || m.modes == 0 || m.modes > MAX_MODES {
            v = v.with(Self::MODE_COUNT);
        }
        let n = m.modes.min(MAX_MODES);
        let mut prev: Option<T> = None;
        for i in 0..n {
            let (Some(&w), Some(&z), Some(&b)) =
                (m.omega_rad_s.get(i), m.zeta.get(i), m.bbar.get(i))
            else {
                return v.with(Self::MODE_COUNT);
            };
            if !(w.is_finite() && z.is_finite() && b.is_finite()) {
                v = v.with(Self::NON_FINITE);
                continue;
            }
            if !(w > T::ZERO) {
                v = v.with(Self::OMEGA_NOT_POSITIVE);
            }
            if !(z > T::ZERO && z < T::ONE) {
                v = v.with(Self::ZETA_OUT_OF_RANGE);
            }
            if prev.is_some_and(|p| !(w > p)) {
                v = v.with(Self::NOT_DISTINCT);
            }
            prev = Some(w);
        }
        v
    }

    /// The flags of a recovery result.
    pub fn of_result<T: Real>(r: &Result<ModalParams<T>, ModalError>, model_modes: usize) -> Self {
        match r {
            Ok(m) => Self::of(m, model_modes),
            Err(_) => Self::NOT_RECOVERED,
        }
    }

    /// True if no flag is set.
    pub const fn is_valid(self) -> bool {
        self.0 == 0
    }

    /// True if every bit of `other` is set.
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    /// `self` with the bits of `other`.
    #[must_use]
    pub const fn with(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }

    /// The names of the set flags, in bit order (`"not_recovered"`,
    /// `"mode_count"`, `"non_finite"`, `"omega_not_positive"`,
    /// `"zeta_out_of_range"`, `"not_distinct"`).
    pub fn names(self) -> impl Iterator<Item = &'static str> {
        const NAMES: [&str; 6] = [
            "not_recovered",
            "mode_count",
            "non_finite",
            "omega_not_positive",
            "zeta_out_of_range",
            "not_distinct",
        ];
        NAMES
            .into_iter()
            .enumerate()
            .filter(move |(i, _)| self.0 & (1 << i) != 0)
            .map(|(_, n)| n)
    }
}

/// What to show for one recovery (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reported<T> {
    /// The estimate to show: physical and finite, or `None` before the
    /// first valid one.
    pub modal: Option<ModalParams<T>>,
    /// Whether `modal` is this recovery's (false: held from an earlier).
    pub current: bool,
    /// This recovery's flags.
    pub validity: Validity,
}

/// Keeps the last physically valid estimate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModalHold<T> {
    last: Option<ModalParams<T>>,
}

impl<T: Real> ModalHold<T> {
    /// Nothing held yet.
    pub fn new() -> Self {
        Self { last: None }
    }

    /// Take a recovery; what to report.
    pub fn update(
        &mut self,
        result: &Result<ModalParams<T>, ModalError>,
        model_modes: usize,
    ) -> Reported<T> {
        let validity = Validity::of_result(result, model_modes);
        match result {
            Ok(m) if validity.is_valid() => {
                self.last = Some(*m);
                Reported {
                    modal: Some(*m),
                    current: true,
                    validity,
                }
            }
            _ => Reported {
                modal: self.last,
                current: false,
                validity,
            },
        }
    }

    /// The last valid estimate.
    pub fn last(&self) -> Option<&ModalParams<T>> {
        self.last.as_ref()
    }

    /// Forget it (a new estimator).
    pub fn reset(&mut self) {
        self.last = None;
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    fn params(w: [f32; 2], z: [f32; 2]) -> ModalParams<f32> {
        ModalParams {
            modes: 2,
            omega_rad_s: [w[0], w[1], 0.0],
            zeta: [z[0], z[1], 0.0],
            bbar: [9.6, 16.1, 0.0],
            output_weight: [-2.0, 2.0, 0.0],
        }
    }

    #[test]
    fn each_reason_sets_its_flag() {
        let ok = params([39.0, 245.0], [0.02, 0.13]);
        assert!(Validity::of(&ok, 2).is_valid());
        assert_eq!(Validity::of(&ok, 3), Validity::MODE_COUNT);
        assert_eq!(
            Validity::of(&params([39.0, 39.0], [0.02, 0.13]), 2),
            Validity::NOT_DISTINCT
        );
        assert_eq!(
            Validity::of(&params([245.0, 39.0], [0.02, 0.13]), 2),
            Validity::NOT_DISTINCT
        );
        let v = Validity::of(&params([-1.0, 39.0], [0.0, 1.0]), 2);
        assert_eq!(
            v,
            Validity::OMEGA_NOT_POSITIVE.with(Validity::ZETA_OUT_OF_RANGE)
        );
        assert_eq!(
            v.names().collect::<Vec<_>>(),
            ["omega_not_positive", "zeta_out_of_range"]
        );
        assert_eq!(
            Validity::of(&params([39.0, f32::NAN], [0.02, 0.13]), 2),
            Validity::NON_FINITE
        );
        let mut m = ok;
        m.bbar[1] = f32::INFINITY;
        assert_eq!(Validity::of(&m, 2), Validity::NON_FINITE);
        assert_eq!(
            Validity::of_result::<f32>(&Err(ModalError::NonFinite), 2),
            Validity::NOT_RECOVERED
        );
    }

    #[test]
    fn hold_reports_the_last_valid_estimate_never_nan() {
        let mut h = ModalHold::<f32>::new();
        let r = h.update(&Err(ModalError::NonFinite), 2);
        assert_eq!((r.modal, r.current), (None, false));
        let ok = params([39.0, 245.0], [0.02, 0.13]);
        let r = h.update(&Ok(ok), 2);
        assert_eq!(
            (r.modal, r.current, r.validity),
            (Some(ok), true, Validity::VALID)
        );
        let bad = params([39.0, f32::NAN], [0.02, 1.3]);
        let r = h.update(&Ok(bad), 2);
        assert_eq!((r.modal, r.current), (Some(ok), false));
        assert!(r.validity.contains(Validity::NON_FINITE));
        h.reset();
        assert!(h.last().is_none());
    }
}
