//! Which of several candidate models a record supports best (`beamctl
//! replay --estimator auto`, the default): the rule, apart from how the
//! candidates are run ([`crate::cli::replay`]).
//!
//! # Rule
//! 1. **Eligible**: the candidate produced an estimate, every mode is
//!    physical (finite ω > 0, 0 < ζ < 1: no [`beamest::modal::Validity`]
//!    flag), a lightly damped bending mode (ζ ≤ [`MAX_ZETA`]) and one the
//!    record holds at least [`MIN_PERIODS`] periods of, and its
//!    model output fit exists (a stable model). A heavily damped "mode" is
//!    the model standing in for something that is not a mode of the beam:
//!    measured on the committed records, a level correction's or an
//!    offset step's transient (ζ ≈ 0.36 and 0.66) and an acceleration
//!    output's direct term fitted by a strain model (ζ ≈ 0.75); a mode
//!    slower than the record stands in for a drift.
//! 2. **Residual**: the model output fit ([`crate::judge::fit`], initial
//!    state fitted) on the record as measured and on the record after the
//!    sensor guard's level correction (offset steps removed, the same
//!    DC-removing high-pass on u and y, which leaves the u → y transfer
//!    function unchanged); the better of the two, as the relative residual
//!    r = ‖y − ŷ‖/‖y − ȳ‖ = 1 − fit/100. Both, because neither alone is
//!    fair: an offset or a drift that no linear model explains spoils the
//!    measured record for every candidate, and the high-pass's own
//!    transient (a record that starts in motion or off its rest level)
//!    spoils the corrected one for a model that is exactly right.
//! 3. **Score**: the Bayesian information criterion of that residual,
//!    BIC = n·ln(r²) + k·ln(n) over the n samples, with k the parameters
//!    fitted: 4N − 1 transfer-function coefficients and 2N initial-state
//!    coefficients for N modes, plus the feedthrough term's two (D and the
//!    s³ numerator coefficient). Under white Gaussian noise on y it is the
//!    log-likelihood, up to a constant, with a penalty that makes a
//!    spurious mode lose unless it explains more than ~k·ln(n)/n of the
//!    residual.
//! 4. **Choice**: among the eligible candidates that are as well
//!    supported as the best, the one first in the preference order the
//!    caller gives (fewer modes, then no level correction, then the
//!    robust estimator before the adaptive law before the feedthrough
//!    model). As well supported: a BIC within [`DECISIVE`] of the lowest
//!    (no strong evidence between them: Kass and Raftery's scale of ΔBIC),
//!    or a residual energy r² within [`EQUIVALENT`] of the lowest. The
//!    second test is for long records: with 10⁵ samples BIC already
//!    prefers a model that explains 0.1% more of the residual. No eligible
//!    candidate: no choice.
//!
//! The rule reads nothing but the record: no truth, no tolerance.

use serde::Serialize;

/// ΔBIC below which two candidates count as equally supported (the
/// "strong evidence" threshold of Kass and Raftery, J. Am. Stat. Assoc.
/// 90 (1995), a Bayes factor of ≈150).
pub const DECISIVE: f64 = 10.0;

/// The largest damping ratio a candidate's mode may have (step 1).
pub const MAX_ZETA: f64 = 0.3;

/// Why a candidate with these damping ratios cannot be chosen
/// (`overdamped_mode`), if so.
pub fn overdamped(zeta: &[f64]) -> Option<&'static str> {
    zeta.iter()
        .any(|&z| z > MAX_ZETA)
        .then_some("overdamped_mode")
}

/// The fewest periods of each mode a record must hold (step 1).
pub const MIN_PERIODS: f64 = 2.0;

/// Why a candidate with these natural frequencies cannot be chosen from a
/// record of `duration_s` (`mode_slower_than_record`: a mode completes
/// fewer than [`MIN_PERIODS`] periods in it), if so. Such a "mode" is the
/// model standing in for a drift of the sensor's level (measured: an
/// acceleration model's third mode at 0.017 rad/s on a 10 s record with a
/// thermal drift), not a mode the record shows.
pub fn slower_than_record(omega: &[f64], duration_s: f64) -> Option<&'static str> {
    omega
        .iter()
        .any(|&w| w * duration_s < MIN_PERIODS * std::f64::consts::TAU)
        .then_some("mode_slower_than_record")
}

/// Relative difference of residual energy (RSS) below which two
/// candidates count as equally supported whatever their BIC: a model must
/// explain 1% more of the residual to be preferred to a simpler one.
pub const EQUIVALENT: f64 = 0.01;

/// What the rule knows about one candidate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evidence {
    /// Why it cannot be chosen (step 1), if so.
    pub excluded: Option<&'static str>,
    /// The relative residual r = ‖y − ŷ‖/‖y − ȳ‖ of its model output fit
    /// (step 2), if it has one.
    pub relative_residual: Option<f64>,
    /// Parameters fitted, k (step 3).
    pub parameters: usize,
}

/// The rule's reading of one candidate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Score {
    /// BIC (step 3); None when excluded.
    pub bic: Option<f64>,
    /// Why it cannot be chosen, if so.
    pub excluded: Option<&'static str>,
}

/// BIC of a relative residual `r` over `n` samples with `k` parameters;
/// None for a non-finite or zero residual or no samples.
pub fn bic(r: f64, n: usize, k: usize) -> Option<f64> {
    if !(r.is_finite() && r > 0.0 && n > 0) {
        return None;
    }
    let n = n as f64;
    Some(n * (r * r).ln() + k as f64 * n.ln())
}

/// Score every candidate over `n` judged samples, and the index of the
/// chosen one (step 4); `candidates` are in the preference order.
pub fn choose(candidates: &[Evidence], n: usize) -> (Vec<Score>, Option<usize>) {
    let scores: Vec<Score> = candidates
        .iter()
        .map(|c| {
            let excluded = c.excluded.or(match c.relative_residual {
                None => Some("no_fit"),
                Some(_) => None,
            });
            let value = match excluded {
                None => c.relative_residual.and_then(|r| bic(r, n, c.parameters)),
                Some(_) => None,
            };
            Score {
                bic: value,
                excluded: excluded.or(value.is_none().then_some("no_fit")),
            }
        })
        .collect();
    let best = scores
        .iter()
        .filter_map(|s| s.bic)
        .fold(f64::INFINITY, f64::min);
    let rss = |c: &Evidence| c.relative_residual.map_or(f64::INFINITY, |r| r * r);
    let best_rss = candidates
        .iter()
        .zip(&scores)
        .filter(|(_, s)| s.bic.is_some())
        .map(|(c, _)| rss(c))
        .fold(f64::INFINITY, f64::min);
    let chosen = candidates.iter().zip(&scores).position(|(c, s)| {
        s.bic
            .is_some_and(|b| b <= best + DECISIVE || rss(c) <= best_rss * (1.0 + EQUIVALENT))
    });
    (scores, chosen)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ok(rms: f64, k: usize) -> Evidence {
        Evidence {
            excluded: None,
            relative_residual: Some(rms),
            parameters: k,
        }
    }

    #[test]
    fn the_first_of_the_equally_supported_is_chosen() {
        // 1e5 samples: a 1e-5 relative RSS change is ΔBIC ≈ 1.
        let n = 100_000;
        let (s, c) = choose(&[ok(1.0, 5), ok(0.99999, 11)], n);
        assert_eq!(c, Some(0), "{s:?}");
        // A decisive improvement wins whatever its place.
        let (_, c) = choose(&[ok(1.0, 5), ok(0.9, 11)], n);
        assert_eq!(c, Some(1));
    }

    #[test]
    fn a_long_record_needs_one_percent_of_the_residual() {
        // 0.2% less residual energy: decisive for BIC at 1e5 samples, but
        // not worth a mode.
        let n = 100_000;
        let (s, c) = choose(&[ok(1.0, 11), ok((1.0f64 - 2e-3).sqrt(), 17)], n);
        assert!(s[1].bic.unwrap() < s[0].bic.unwrap() - DECISIVE);
        assert_eq!(c, Some(0));
        // 2% less: the mode is worth it.
        let (_, c) = choose(&[ok(1.0, 11), ok((1.0f64 - 2e-2).sqrt(), 17)], n);
        assert_eq!(c, Some(1));
    }

    #[test]
    fn a_spurious_mode_loses_to_its_penalty() {
        // Six more parameters that take 1e-5 of the residual's energy.
        let n = 100_000;
        let (s, c) = choose(&[ok(1.0, 17), ok(1.0 - 5e-6, 23)], n);
        assert_eq!(c, Some(0));
        assert!(s[1].bic.unwrap() > s[0].bic.unwrap() + DECISIVE);
    }

    #[test]
    fn excluded_and_fitless_candidates_are_never_chosen() {
        let bad = Evidence {
            excluded: Some("zeta_out_of_range"),
            relative_residual: Some(1e-9),
            parameters: 1,
        };
        let fitless = Evidence {
            excluded: None,
            relative_residual: None,
            parameters: 1,
        };
        let (s, c) = choose(&[bad, fitless, ok(1.0, 5)], 1000);
        assert_eq!(c, Some(2));
        assert_eq!(s[0].excluded, Some("zeta_out_of_range"));
        assert_eq!(s[1].excluded, Some("no_fit"));
        assert_eq!(s[0].bic, None);
        let (_, c) = choose(&[bad, fitless], 1000);
        assert_eq!(c, None);
    }
}
