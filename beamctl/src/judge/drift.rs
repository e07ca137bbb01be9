//! The drift indicator: how much an estimate moved over the last tenth of
//! the span it is judged on (a record for `replay`/`simulate`, the
//! monitor's window of the live stream), robust to a transient excursion
//! of a converged estimate (the verdict's `drifting`,
//! [`crate::judge::verdict`]).

use beamest::model::ModalParams;

/// ω̂, ζ̂ over time, kept to measure the drift at the end.
#[derive(Debug, Default, Clone)]
pub struct History {
    t: Vec<f64>,
    values: Vec<Option<Vec<f64>>>,
}

impl History {
    /// Note the estimate at `t` (s): its modes' ω, ζ, or `None` when
    /// recovery failed.
    pub fn push(&mut self, t: f64, m: Option<&ModalParams<f64>>) {
        self.push_values(
            t,
            m.map(|m| {
                let n = m.modes;
                m.omega_rad_s[..n]
                    .iter()
                    .chain(&m.zeta[..n])
                    .copied()
                    .collect()
            }),
        );
    }

    /// Note ω̂_1.., ζ̂_1.. at `t` (s) as one list, or `None` when recovery
    /// failed. Times must not decrease.
    pub fn push_values(&mut self, t: f64, values: Option<Vec<f64>>) {
        self.t.push(t);
        self.values.push(values);
    }

    /// Forget the estimates before `t` (s).
    pub fn forget_before(&mut self, t: f64) {
        let n = self.t.partition_point(|&s| s < t);
        self.t.drain(..n);
        self.values.drain(..n);
    }

    /// How much the estimate moved over the last 10% of [`start_s`,
    /// `end_s`]: over the estimates in it, split into an earlier and a
    /// later half, the largest |median(later) − median(earlier)| /
    /// |median(later)| of ω̂_i, ζ̂_i (`None` if recovery failed in it or it
    /// holds fewer than two). A steady trend
    /// reads about half its span over the window; a transient excursion of
    /// fewer than half of either half's estimates does not move a median,
    /// so a converged estimate with one outlying evaluation reads as
    /// converged.
    pub fn drift(&self, start_s: f64, end_s: f64) -> Option<f64> {
        let from = end_s - 0.1 * (end_s - start_s);
        let start = self.t.partition_point(|&t| t < from);
        let window = &self.values[start..];
        if window.len() < 2 {
            return None;
        }
        let rows = window
            .iter()
            .map(Option::as_ref)
            .collect::<Option<Vec<_>>>()?;
        let (earlier, later) = rows.split_at(rows.len() / 2);
        let median_of = |half: &[&Vec<f64>], j: usize| -> Option<f64> {
            let mut v: Vec<f64> = half
                .iter()
                .map(|r| r.get(j).copied())
                .collect::<Option<_>>()?;
            v.sort_by(f64::total_cmp);
            let n = v.len();
            Some(if n % 2 == 1 {
                v[n / 2]
            } else {
                0.5 * (v[n / 2 - 1] + v[n / 2])
            })
        };
        let mut worst = 0.0f64;
        for j in 0..rows.last()?.len() {
            let (a, b) = (median_of(earlier, j)?, median_of(later, j)?);
            worst = worst.max((b - a).abs() / b.abs());
        }
        worst.is_finite().then_some(worst)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drift_spans_the_last_tenth() {
        let mut h = History::default();
        let m = |w: f64| ModalParams::new(&[w], &[0.1], &[1.0], None).unwrap();
        for k in 0..=100 {
            let t = k as f64 * 0.1;
            // Moves by 1% in the first 90%, then by 1e-4 in the last 10%.
            let w = if t < 9.0 {
                100.0 + t / 9.0
            } else {
                101.0 + (t - 9.0) * 1e-2
            };
            h.push(t, Some(&m(w)));
        }
        // The 11 evaluations from 9.0 s: medians at 9.2 s and 9.75 s.
        let d = h.drift(0.0, 10.0).unwrap();
        let expected = 0.0055 / 101.0075;
        assert!((d - expected).abs() < 1e-9, "{d}");
        h.push(10.1, None);
        assert_eq!(h.drift(0.0, 10.1), None);
    }

    #[test]
    fn a_transient_excursion_of_a_converged_estimate_is_not_drift() {
        let m = |w: f64| ModalParams::new(&[w], &[0.1], &[1.0], None).unwrap();
        let run = |spike: Option<usize>, step: f64| {
            let mut h = History::default();
            for k in 0..=100 {
                let t = k as f64 * 0.1;
                let mut w = if t < 9.45 { 100.0 } else { 100.0 + step };
                if spike == Some(k) {
                    // One evaluation 46.7% off, as a record's transient.
                    w *= 1.467;
                }
                h.push(t, Some(&m(w)));
            }
            h.drift(0.0, 10.0).unwrap()
        };
        assert_eq!(run(None, 0.0), 0.0);
        assert_eq!(run(Some(93), 0.0), 0.0, "one outlying evaluation");
        assert_eq!(
            run(Some(98), 0.0),
            0.0,
            "one outlying evaluation, later half"
        );
        // A real move in the window (a plant change) still reads: the step.
        let d = run(Some(93), 1.0);
        assert!((d - 1.0 / 101.0).abs() < 1e-12, "{d}");
    }

    #[test]
    fn a_window_judges_its_own_last_tenth() {
        let mut h = History::default();
        // 100 s of a converged estimate, then forget all but the last 20 s:
        // the window [80, 100] s judges [98, 100] s.
        for k in 0..=1000 {
            let t = k as f64 * 0.1;
            let w = if t < 99.05 { 100.0 } else { 102.0 };
            h.push_values(t, Some(vec![w, 0.01]));
        }
        h.forget_before(80.0);
        let d = h.drift(80.0, 100.0).unwrap();
        assert!((d - 2.0 / 102.0).abs() < 1e-12, "{d}");
        // Over the whole 100 s the last tenth starts at 90 s: the step is
        // in its later half only.
        assert!(h.drift(0.0, 100.0).is_some());
        // A failed recovery in the window: no drift can be measured.
        h.push_values(100.1, None);
        assert_eq!(h.drift(80.0, 100.1), None);
    }
}
