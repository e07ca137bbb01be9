//! Host decoding throughput (BENCHMARKS.md, "Serial link: host decoding"):
//! frames per second that the host side of `beamctl monitor` handles, on
//! two streams made by the fake device (`beamctl::link::fake`):
//!
//! * `default`: the protocol's default telemetry (estimates at 100 Hz,
//!   status at 1 Hz; 2 modes);
//! * `raw`: the heaviest load 921,600 baud carries next to them: raw
//!   samples at 5 kHz (decimation 2), in blocks of 64 pairs.
//!
//! and three depths of processing, each fed in 16 KiB chunks as a serial
//! port or socket delivers them:
//!
//! * `decoder`: the core's `protocol::Decoder` alone (COBS, CRC, postcard,
//!   sequence check);
//! * `host`: `beamctl::link::Host::receive` (the decoder plus the host's
//!   bookkeeping: Status, rates);
//! * `host+record`: plus `beamctl::link::Recorder` writing every frame and
//!   every raw sample to CSV files (`--record`), the monitor's heaviest
//!   per-frame work.
//!
//! ```sh
//! cargo run --release -p beamctl --example decode_throughput
//! ```
//!
//! Each figure is the median of 5 runs over 600 s of device time.

use beam_protocol::budget::uart_bytes_per_s;
use beam_protocol::{Decoder, TelemetryRates};
use beamctl::link::fake::{FakeConfig, FakeDevice};
use beamctl::link::{Host, Recorder};
use std::time::Instant;

const DEVICE_SECONDS: u64 = 600;
const RUNS: usize = 5;
const CHUNK: usize = 16 * 1024;

fn stream(raw_decimation: u16) -> Vec<u8> {
    let cfg = FakeConfig {
        rates: TelemetryRates {
            raw_decimation,
            ..TelemetryRates::default()
        },
        ..FakeConfig::default()
    };
    let mut dev = FakeDevice::new(cfg);
    let mut out = Vec::new();
    dev.advance(DEVICE_SECONDS * 10_000, &mut out);
    out
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Median wall time (s) of `f` over the stream, and the frames it saw.
fn time(bytes: &[u8], mut f: impl FnMut(&[u8]) -> u64) -> (f64, u64) {
    let mut times = Vec::new();
    let mut frames = 0;
    for _ in 0..RUNS {
        let t0 = Instant::now();
        frames = f(bytes);
        times.push(t0.elapsed().as_secs_f64());
    }
    (median(times), frames)
}

fn main() {
    let dir = std::env::temp_dir().join(format!("beamctl-decode-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let link_b_s = f64::from(uart_bytes_per_s(921_600));
    println!(
        "{:<8} {:<12} {:>9} {:>10} {:>12} {:>9} {:>16}",
        "stream", "depth", "frames", "MB", "frames/s", "MB/s", "x 921600 baud"
    );
    for (name, d) in [("default", 0u16), ("raw", 2)] {
        let bytes = stream(d);
        let mb = bytes.len() as f64 / 1e6;
        let report = |depth: &str, (t, frames): (f64, u64)| {
            println!(
                "{name:<8} {depth:<12} {frames:>9} {mb:>10.2} {:>12.3e} {:>9.1} {:>16.0}",
                frames as f64 / t,
                mb / t,
                // How many such links one core keeps up with.
                bytes.len() as f64 / t / link_b_s
            );
        };
        report(
            "decoder",
            time(&bytes, |b| {
                let mut d: Decoder = Decoder::new();
                for c in b.chunks(CHUNK) {
                    d.feed(c).for_each(drop);
                }
                d.counters().frames_ok
            }),
        );
        report(
            "host",
            time(&bytes, |b| {
                let mut h = Host::new(false);
                let now = Instant::now();
                for c in b.chunks(CHUNK) {
                    h.receive(c, now);
                }
                h.counters().frames_ok
            }),
        );
        let path = dir.join(format!("{name}.csv"));
        report(
            "host+record",
            time(&bytes, |b| {
                let mut h = Host::new(false);
                let mut r = Recorder::create(&path).expect("record file");
                let t0 = Instant::now();
                for c in b.chunks(CHUNK) {
                    let now = Instant::now();
                    for f in h.receive(c, now).into_iter().flatten() {
                        r.frame(now.duration_since(t0).as_secs_f64(), &f, &h)
                            .expect("record");
                    }
                    r.flush_if_due(now).expect("flush");
                }
                r.finish().expect("finish");
                h.counters().frames_ok
            }),
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
