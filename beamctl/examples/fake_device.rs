//! A fake device on a TCP port, to try `beamctl monitor` and `beamctl send`
//! without a rig (see `beamctl::link::fake` for what it sends; its
//! estimates are not estimated, they approach fixed values):
//!
//! ```sh
//! cargo run -p beamctl --example fake_device -- --listen 127.0.0.1:4000 &
//! cargo run -p beamctl -- monitor --tcp 127.0.0.1:4000
//! ```
//!
//! It serves one connection at a time, each from start-up (sample 0,
//! sequence number 0), until the client leaves or `--close-after` seconds
//! (then it closes the connection, as an unplugged device would).
//!
//! `--write FILE --samples N` writes instead the bytes the device sends
//! over its first N samples to FILE (a capture, as `beamctl monitor
//! --capture` would record it) and exits.

use beamctl::link::fake::{FakeConfig, FakeDevice, ServeOptions};
use clap::Parser;
use std::net::TcpListener;
use std::time::Duration;

#[derive(Parser)]
struct Args {
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1:4000")]
    listen: String,
    /// Raw samples: every d-th sample (0 = off).
    #[arg(long, default_value_t = 0)]
    raw_decimation: u16,
    /// Close each connection after this many seconds.
    #[arg(long)]
    close_after: Option<f64>,
    /// Never answer commands.
    #[arg(long)]
    mute: bool,
    /// Write the bytes of the first --samples samples to this file and
    /// exit, instead of listening.
    #[arg(long, requires = "samples")]
    write: Option<std::path::PathBuf>,
    /// Samples (at the device's 10 kHz) for --write.
    #[arg(long)]
    samples: Option<u64>,
}

fn main() -> std::io::Result<()> {
    let args = Args::parse();
    if let (Some(path), Some(n)) = (&args.write, args.samples) {
        let mut cfg = FakeConfig::default();
        cfg.rates.raw_decimation = args.raw_decimation;
        let mut dev = FakeDevice::new(cfg);
        let mut bytes = Vec::new();
        dev.advance(n, &mut bytes);
        std::fs::write(path, &bytes)?;
        eprintln!("wrote {} bytes to {}", bytes.len(), path.display());
        return Ok(());
    }
    let listener = TcpListener::bind(&args.listen)?;
    eprintln!("fake device listening on {}", listener.local_addr()?);
    for stream in listener.incoming() {
        let stream = stream?;
        eprintln!("connection from {}", stream.peer_addr()?);
        stream.set_read_timeout(Some(Duration::from_millis(50)))?;
        let mut cfg = FakeConfig::default();
        cfg.rates.raw_decimation = args.raw_decimation;
        cfg.answers_commands = !args.mute;
        let mut dev = FakeDevice::new(cfg);
        let opts = ServeOptions {
            close_after: args.close_after.map(Duration::from_secs_f64),
            ..ServeOptions::default()
        };
        let end = dev.serve(stream.try_clone()?, stream.try_clone()?, &opts);
        let _ = stream.shutdown(std::net::Shutdown::Both);
        let log = dev.log();
        eprintln!(
            "{end:?}: sent {} estimates, {} raw blocks, {} status; {} commands",
            log.estimates,
            log.raw_frames,
            log.statuses,
            log.commands.len()
        );
    }
    Ok(())
}
