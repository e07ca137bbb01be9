//! `cargo xtask qemu --e2e`, check 4: the automatic tuning rule on the
//! device, judged from the Status frames and the device's own final
//! estimate (see the module doc of `e2e`).

use beam_protocol::Status;

/// The λ fixed for a moment before returning to the automatic rule
/// (rad/s): half the paper's band centre, so the rule must re-centre.
pub const FIXED_LAMBDA: f32 = 50.0;
/// The rule's re-centring threshold (`TuningConfig::recentre_threshold`).
const RECENTRE_THRESHOLD: f64 = 0.1;

/// Check 4: no λ in the first Status (window open), λ = [`FIXED_LAMBDA`]
/// right after `SetEstimator` none, and the last Status's λ re-centred on
/// `band_centre` = √(ω̂1·ω̂2) of the last valid estimate. Failures are
/// pushed to `fails`, passes printed.
pub fn check(
    first_status: Option<&Status>,
    after_auto: Option<&Status>,
    last_status: Option<&Status>,
    band_centre: Option<f64>,
    fails: &mut Vec<String>,
) {
    let pass = |what: String| println!("e2e: ok: {what}");
    match first_status.map(|s| (s.estimator.lambda_rad_s, s.lambda_automatic)) {
        Some((None, true)) => {
            pass("first Status (start-up window): no lambda yet, lambda_automatic".into())
        }
        l => fails.push(format!(
            "first Status: (lambda, automatic) {l:?}, expected (None, true) (automatic rule, \
             window open)"
        )),
    }
    match after_auto.map(|s| (s.estimator.lambda_rad_s, s.lambda_automatic)) {
        Some((Some(l), true)) if l == FIXED_LAMBDA => pass(format!(
            "SetEstimator lambda {FIXED_LAMBDA} then none accepted; Status: lambda {l}, \
             lambda_automatic (the rule continues from the lambda in use)"
        )),
        l => fails.push(format!(
            "Status after SetEstimator(none): (lambda, automatic) {l:?}, expected \
             (Some({FIXED_LAMBDA}), true)"
        )),
    }
    let last_lambda = last_status
        .and_then(|s| s.estimator.lambda_rad_s)
        .map(f64::from);
    match (last_lambda, band_centre) {
        (Some(l), Some(c)) => {
            let off = |a: f64, b: f64| (a / b).max(b / a) - 1.0;
            let moved = off(l, f64::from(FIXED_LAMBDA));
            if off(l, c) < RECENTRE_THRESHOLD && moved > RECENTRE_THRESHOLD {
                pass(format!(
                    "automatic rule re-centred lambda from {FIXED_LAMBDA} to {l:.1} rad/s, within \
                     {:.1}% of the estimate's band centre {c:.1} rad/s",
                    100.0 * off(l, c)
                ));
            } else {
                fails.push(format!(
                    "last Status lambda {l:.1} rad/s: not re-centred on the estimate's band \
                     centre {c:.1} rad/s (or still at {FIXED_LAMBDA})"
                ));
            }
        }
        (l, c) => fails.push(format!(
            "no final lambda ({l:?}) or no estimated band ({c:?})"
        )),
    }
}
