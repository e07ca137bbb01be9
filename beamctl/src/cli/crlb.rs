//! `beamctl crlb`: the Cramér–Rao bound of the experiment `beamctl
//! simulate` would run with the same flags ([`crate::judge::bound`]), before it
//! is run.

use crate::cli::args::CrlbArgs;
use crate::cli::simulate::plan::{
    check_duration, check_noise, check_ts, drive_excitation, drive_text,
};
use crate::error::write_stdout;
use crate::error::CliError;
use crate::io::report;
use crate::io::table::{rel, sig, Column, Table};
use crate::judge::bound::{model_set_description, ExperimentBound, NoiseLevel};
use crate::run::drive::drive;
use crate::run::interrupt::Interrupt;
use crate::run::samples;
use crate::run::RunConfig;
use serde::Serialize;

/// Run `beamctl crlb`.
pub fn run(args: &CrlbArgs) -> Result<(), CliError> {
    write_stdout(&output(args)?)
}

/// What `beamctl crlb` prints (the JSON document with `--json`).
pub fn output(args: &CrlbArgs) -> Result<String, CliError> {
    output_with(args, None)
}

/// [`output`], with `interrupt` asked every few thousand samples of the
/// Fisher information's accumulation: true stops it with an error whose
/// code is [`crate::error::EXIT_INTERRUPTED`].
pub fn output_with(
    args: &CrlbArgs,
    interrupt: Option<&mut dyn FnMut() -> bool>,
) -> Result<String, CliError> {
    check_ts(args.ts)?;
    check_duration(args.duration, args.ts)?;
    check_noise(args.snr_db, args.noise_sd)?;
    let (plant, modes, label) = crate::cli::plant_flags::resolve(&args.plant, args.ts)?;
    let cfg = RunConfig {
        plant,
        duration_s: args.duration,
        ts_s: args.ts,
        excitation: drive_excitation(&args.excitation)?,
        output: args.output.or_strain(),
        ..RunConfig::default()
    };
    let noise = match (args.snr_db, args.noise_sd) {
        (_, Some(sd)) => NoiseLevel::Sd(sd),
        (Some(db), None) => NoiseLevel::SnrDb(db),
        // clap requires one of the two.
        (None, None) => return Err(CliError::usage("--snr-db", "or --noise-sd is required")),
    };
    let set = args.model_set.set();
    let truth = cfg.truth();
    let u = drive(&cfg).map_err(|e| CliError::usage("--wave", e))?;
    let n = samples(&cfg);
    let mut interrupt = Interrupt::new(interrupt);
    let bound = crate::judge::bound::experiment_bound(
        &truth.tf,
        &truth.modal.output_weight[..modes],
        cfg.ts_s,
        u.take(n as usize).take_while(|_| !interrupt.stopped()),
        noise,
        set,
    );
    if interrupt.fired() {
        return Err(CliError::interrupted("crlb"));
    }
    let bound = bound.map_err(|e| CliError::failure(format!("crlb: {e}")))?;
    let text = if args.json {
        #[derive(Serialize)]
        struct Doc<'a> {
            plant: &'a str,
            duration_s: f64,
            /// The drive, in words (the "experiment:" line's).
            drive: String,
            /// The paper's square wave's amplitude and frequency, when it
            /// is the drive.
            #[serde(skip_serializing_if = "Option::is_none")]
            u_amplitude: Option<f64>,
            #[serde(skip_serializing_if = "Option::is_none")]
            u_freq_hz: Option<f64>,
            #[serde(flatten)]
            bound: &'a ExperimentBound,
        }
        let square = cfg.excitation.is_none();
        report::to_json(&[Doc {
            plant: &label,
            duration_s: n as f64 * cfg.ts_s,
            drive: drive_text(&cfg),
            u_amplitude: square.then_some(cfg.u_amplitude),
            u_freq_hz: square.then_some(cfg.u_freq_hz),
            bound: &bound,
        }])?
    } else {
        render(&cfg, &label, &bound, set)
    };
    Ok(text)
}

/// Heading and one row per parameter: value, absolute and relative 1σ.
fn render(
    cfg: &RunConfig,
    label: &str,
    b: &ExperimentBound,
    set: beamest::crlb::ModelSet,
) -> String {
    let n = b.modes;
    let mut out = format!(
        "plant:      {label}, {n} mode{}\n",
        if n == 1 { "" } else { "s" }
    );
    out.push_str(&format!(
        "experiment: {} s at Ts = {} ms ({} samples), u = {} from rest, white noise on y: σ = {} (SNR {:.2} dB over the noise-free y's RMS {})\n",
        b.samples as f64 * cfg.ts_s,
        cfg.ts_s * 1e3,
        b.samples,
        drive_text(cfg),
        sig(b.sigma, 4),
        b.snr_db,
        sig(b.rms_y, 4),
    ));
    out.push_str(&format!(
        "model set:  {}\n\n",
        model_set_description(set, n)
    ));
    let mut t = Table::new();
    t.group(
        "",
        vec![
            Column::text("parameter"),
            Column::num("value"),
            Column::num("CRB (1σ)"),
            Column::num("relative"),
        ],
    );
    let rows: [(&str, &str, &crate::judge::bound::ParamBound); 3] = [
        ("ω", " (rad/s)", &b.omega),
        ("ζ", "", &b.zeta),
        ("b̄", "", &b.bbar),
    ];
    for (sym, unit, p) in rows {
        for i in 0..n {
            t.row([
                format!("{sym}{}{unit}", i + 1),
                sig(p.value[i], 7),
                format!("{:.3e}", p.sd[i]),
                rel(p.rel[i]),
            ]);
        }
    }
    out.push_str(&t.render());
    out.push_str(
        "\nCRB: the smallest standard deviation any unbiased estimator of this model set can \
reach on this experiment (Fisher information of the sampled y; beamest::crlb). It scales \
with σ and falls with the record length; most of the information on the first mode is in \
the seconds after the excitation starts from rest. b̄ = α/c (the modal split of the \
numerator); in the transfer-function set its bound follows by the delta method through \
eq. 32.\n",
    );
    out
}
