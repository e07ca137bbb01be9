//! End-to-end tests of `beamctl monitor` and `beamctl send` against the
//! fake device (`beamctl::link::fake`) over TCP and a pseudo-terminal, and
//! against captured byte files with corruption.
//!
//! Counts that depend on how long a run lasts are checked by range or by
//! consistency (every estimate printed is recorded, indices step exactly),
//! never against wall-clock times.

use beam_protocol::{
    encode_raw, Command, Decoder, Excitation, Header, Kind, LinkCounters, TelemetryRates, Waveform,
};
use beamctl::link::fake::{FakeConfig, FakeDevice, ServeOptions};
use beamctl::link::record::columns;
use std::io::Write;
use std::net::{Shutdown, TcpListener};
use std::path::{Path, PathBuf};
use std::process::{Command as Process, Output, Stdio};
use std::thread::JoinHandle;
use std::time::Duration;

fn beamctl(args: &[&str]) -> Output {
    Process::new(env!("CARGO_BIN_EXE_beamctl"))
        .args(args)
        .output()
        .expect("run beamctl")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("beamctl-monitor");
    std::fs::create_dir_all(&dir).expect("scratch dir");
    let p = dir.join(name);
    let _ = std::fs::remove_file(&p);
    p
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// A fake device serving one TCP connection; the thread returns it when the
/// connection ends (the client left, or `close_after`).
fn fake_tcp(cfg: FakeConfig, close_after: Option<Duration>) -> (String, JoinHandle<FakeDevice>) {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = listener.local_addr().expect("addr").to_string();
    let h = std::thread::spawn(move || {
        let (stream, _) = listener.accept().expect("accept");
        stream
            .set_read_timeout(Some(Duration::from_millis(20)))
            .expect("timeout");
        let mut dev = FakeDevice::new(cfg);
        let opts = ServeOptions {
            close_after,
            ..ServeOptions::default()
        };
        dev.serve(
            stream.try_clone().expect("clone"),
            stream.try_clone().expect("clone"),
            &opts,
        );
        let _ = stream.shutdown(Shutdown::Both);
        dev
    });
    (addr, h)
}

fn raw_on() -> FakeConfig {
    FakeConfig {
        rates: TelemetryRates {
            estimate_rate_hz: 100.0,
            raw_decimation: 10,
            status_rate_hz: 2.0,
        },
        ..FakeConfig::default()
    }
}

/// The CSV rows of `path` (header first).
fn csv_rows(path: &Path) -> Vec<csv::StringRecord> {
    let mut r = csv::ReaderBuilder::new()
        .has_headers(false)
        .from_path(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    r.records().map(|x| x.expect("csv row")).collect()
}

fn col(header: &csv::StringRecord, name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name}"))
}

/// `key=value` from a plain estimate line.
fn field<'a>(line: &'a str, key: &str) -> &'a str {
    line.split_whitespace()
        .find_map(|kv| kv.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
        .unwrap_or_else(|| panic!("no {key} in {line}"))
}

/// The counters of the summary line `link: N frames, L lost …`.
fn summary_counters(err: &str) -> LinkCounters {
    let line = err
        .lines()
        .find(|l| l.starts_with("link: ") && l.contains(" frames, "))
        .unwrap_or_else(|| panic!("no summary in {err}"));
    let num = |label: &str| -> u64 {
        let i = line
            .find(label)
            .unwrap_or_else(|| panic!("no {label} in {line}"));
        let before = line[..i].trim_end();
        let start = before.rfind([' ', '(']).map_or(0, |k| k + 1);
        before[start..].parse().expect("count")
    };
    LinkCounters {
        bytes: num(" bytes ("),
        skipped_bytes: num(" skipped while joining"),
        frames_ok: num(" frames,"),
        crc_errors: num(" CRC errors"),
        framing_errors: num(" framing errors"),
        oversize: num(" oversize"),
        malformed: num(" malformed"),
        version_mismatches: num(" version mismatches"),
        lost: num(" lost (sequence gaps)"),
        duplicates: num(" duplicates"),
        out_of_order: num(" out of order"),
    }
}

#[test]
fn capture_with_corruption_counts_as_the_decoder_does() {
    // Two seconds of the fake device: estimates, raw blocks, status.
    let mut dev = FakeDevice::new(raw_on());
    let mut clean = Vec::new();
    dev.advance(20_000, &mut clean);
    let frames: Vec<&[u8]> = clean.split_inclusive(|&b| b == 0).collect();
    assert!(frames.len() > 200, "{}", frames.len());
    let mut bytes = Vec::new();
    for (i, f) in frames.iter().enumerate() {
        let mut f = f.to_vec();
        match i {
            // One bit flipped inside a frame.
            5 => {
                let k = f.len() / 2;
                f[k] ^= 0x10;
                if f[k] == 0 {
                    f[k] = 0x10;
                }
            }
            // A frame lost on the way.
            10 => continue,
            // Line noise between two frames.
            30 => f.extend_from_slice(&[0x01, 0x02, 0x03, 0x00]),
            // A delimiter lost: frames 40 and 41 merge.
            40 => *f.last_mut().unwrap() = 0x55,
            _ => {}
        }
        bytes.extend_from_slice(&f);
    }
    // The capture ends in the middle of a frame.
    let cut = frames[7];
    bytes.extend_from_slice(&cut[..cut.len() / 2]);
    let capture = scratch("corrupt.bin");
    std::fs::write(&capture, &bytes).unwrap();

    // What the core's decoder counts on the same bytes.
    let mut d: Decoder = Decoder::new();
    let delivered: Vec<_> = d.feed(&bytes).flatten().collect();
    let want = *d.counters();
    assert_eq!(want.lost, 4, "frames 5, 10, 40, 41");
    assert_eq!(want.errors(), 3, "frame 5, the noise, the merged pair");

    let record = scratch("corrupt.csv");
    let o = beamctl(&[
        "monitor",
        "--file",
        s(&capture),
        "--plain",
        "--record",
        s(&record),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert_eq!(summary_counters(&err), want, "{err}");
    assert!(
        err.contains(&format!(
            "{} bytes after the last frame delimiter were not decoded",
            cut.len() / 2
        )),
        "{err}"
    );
    let estimates = delivered
        .iter()
        .filter(|f| f.message.kind() == Kind::Estimate)
        .count();
    assert_eq!(stdout(&o).lines().count(), estimates);
    let rows = csv_rows(&record);
    let kind = col(&rows[0], "kind");
    let count = |k: &str| rows.iter().filter(|r| &r[kind] == k).count() as u64;
    assert_eq!(count("error"), want.errors());
    assert_eq!(
        count("estimate") + count("raw") + count("status") + count("ack"),
        want.frames_ok
    );
    assert_eq!(&rows.last().unwrap()[kind], "end");
}

#[test]
fn the_verdict_judges_the_stream_and_says_why() {
    // Three seconds of the fake device with every sample sent. Its y is a
    // fixed two-tone signal that its own estimates do not explain: the
    // verdict over the stream must say so.
    let mut dev = FakeDevice::new(FakeConfig {
        rates: TelemetryRates {
            estimate_rate_hz: 10.0,
            raw_decimation: 1,
            status_rate_hz: 1.0,
        },
        ..FakeConfig::default()
    });
    let mut bytes = Vec::new();
    dev.advance(30_000, &mut bytes);
    let capture = scratch("verdict.bin");
    std::fs::write(&capture, &bytes).expect("write capture");
    let o = beamctl(&[
        "monitor",
        "--file",
        s(&capture),
        "--plain",
        "--verdict-window",
        "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // stdout: one line per estimate; the verdict lines go to stderr.
    assert!(stdout(&o).lines().all(|l| l.starts_with("sample=")));
    let err = stderr(&o);
    let verdicts: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("verdict sample="))
        .collect();
    assert!(!verdicts.is_empty(), "{err}");
    let last = verdicts.last().unwrap();
    assert_eq!(field(last, "trusted"), "no", "{last}");
    assert!(
        field(last, "reasons").contains("residual_structured"),
        "{last}"
    );
    assert!(
        err.contains("over the last 2 s: 20000 raw samples): trusted no:"),
        "{err}"
    );
    assert!(
        err.contains("  residual_structured: the residual y − ŷ is not white"),
        "{err}"
    );
    // Decimated raw samples: no fit, and the summary says how to get one.
    let mut dev = FakeDevice::new(raw_on());
    let mut bytes = Vec::new();
    dev.advance(30_000, &mut bytes);
    std::fs::write(&capture, &bytes).expect("write capture");
    let o = beamctl(&["monitor", "--file", s(&capture), "--plain"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("no_fit: no model-output fit: the raw samples are decimated"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn tcp_end_to_end_plain_record_raw_and_plot() {
    let (addr, dev) = fake_tcp(raw_on(), None);
    let record = scratch("e2e.csv");
    let plot = scratch("e2e.png");
    let o = beamctl(&[
        "monitor",
        "--tcp",
        &addr,
        "--plain",
        "--duration",
        "1.5",
        "--record",
        s(&record),
        "--plot",
        s(&plot),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let dev = dev.join().expect("device");
    let out = stdout(&o);
    let lines: Vec<&str> = out.lines().collect();
    // 100 estimates/s for 1.5 s, give or take the start-up.
    assert!((50..=160).contains(&lines.len()), "{}", lines.len());
    let mut prev: Option<u64> = None;
    for l in &lines {
        let k: u64 = field(l, "sample").parse().unwrap();
        assert_eq!(k % 100, 99, "{l}");
        if let Some(p) = prev {
            assert_eq!(k, p + 100, "no estimate missing");
        }
        prev = Some(k);
        assert_eq!(field(l, "t_s"), (k as f64 / 1e4).to_string());
        assert_eq!(field(l, "law"), "adaptive");
        assert_eq!(field(l, "omega_rad_s").split(',').count(), 2);
        assert!(field(l, "flags").contains("PHYSICALLY_VALID"));
    }
    let err = stderr(&o);
    assert!(err.contains("#0 status: accepted"), "{err}");
    assert_eq!(summary_counters(&err).lost, 0);
    assert_eq!(summary_counters(&err).errors(), 0);

    // The frames file.
    let rows = csv_rows(&record);
    assert_eq!(rows[0].iter().collect::<Vec<_>>(), columns());
    let (kind, omega, seq) = (
        col(&rows[0], "kind"),
        col(&rows[0], "omega_1"),
        col(&rows[0], "seq"),
    );
    let est: Vec<_> = rows.iter().filter(|r| &r[kind] == "estimate").collect();
    assert_eq!(est.len(), lines.len(), "every estimate printed is recorded");
    for (r, l) in est.iter().zip(&lines) {
        assert_eq!(
            &r[omega],
            field(l, "omega_rad_s").split(',').next().unwrap()
        );
        assert_eq!(&r[seq], field(l, "seq"));
    }
    let command = rows
        .iter()
        .find(|r| &r[kind] == "command")
        .expect("command row");
    assert_eq!(&command[col(&rows[0], "detail")], "status");
    let ack = rows.iter().find(|r| &r[kind] == "ack").expect("ack row");
    assert_eq!(&ack[col(&rows[0], "result")], "accepted");
    assert!(rows.iter().any(|r| &r[kind] == "status"
        && &r[col(&rows[0], "sample_rate_hz")] == "10000"
        && &r[col(&rows[0], "waveform")] == "square"));
    let last = rows.last().unwrap();
    assert_eq!(&last[kind], "end");
    assert_eq!(&last[col(&rows[0], "detail")], "--duration elapsed");
    let raw_blocks = rows.iter().filter(|r| &r[kind] == "raw").count();
    assert!(raw_blocks > 5);
    assert!(dev.log().raw_frames >= raw_blocks as u64);

    // The raw file: t,u,y, t from the sample index and the Status's rate,
    // the device's exact values.
    let raw = csv_rows(&beamctl::link::raw_path_for(&record));
    assert_eq!(raw[0].iter().collect::<Vec<_>>(), ["t", "u", "y"]);
    assert_eq!(raw.len() - 1, 64 * raw_blocks);
    for (i, r) in raw[1..].iter().enumerate() {
        let index = 10 * i as u64;
        assert_eq!(r[0].parse::<f64>().unwrap(), index as f64 / 1e4, "row {i}");
        let (u, y) = FakeDevice::signals(&Excitation::default(), 1e4, index);
        assert_eq!(r[1].parse::<f64>().unwrap(), f64::from(u), "row {i}");
        assert_eq!(r[2].parse::<f64>().unwrap(), f64::from(y), "row {i}");
    }
    let png = std::fs::read(&plot).expect("plot");
    assert!(png.starts_with(b"\x89PNG") && png.len() > 10_000);
}

#[test]
fn tcp_peer_that_closes_is_an_error_and_the_record_is_kept() {
    let (addr, dev) = fake_tcp(raw_on(), Some(Duration::from_millis(700)));
    let record = scratch("closed.csv");
    let o = beamctl(&[
        "monitor",
        "--tcp",
        &addr,
        "--plain",
        "--record",
        s(&record),
        "--duration",
        "20",
    ]);
    let dev = dev.join().expect("device");
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains(&format!(
            "error: TCP {addr}: the device closed the connection"
        )),
        "{err}"
    );
    assert!(err.contains("wrote "), "{err}");
    let rows = csv_rows(&record);
    let kind = col(&rows[0], "kind");
    let estimates = rows.iter().filter(|r| &r[kind] == "estimate").count() as u64;
    // Everything the device sent is in the record.
    assert_eq!(estimates, dev.log().estimates);
    assert_eq!(stdout(&o).lines().count() as u64, estimates);
    let raw = csv_rows(&beamctl::link::raw_path_for(&record));
    assert_eq!(
        raw.len() as u64 - 1,
        64 * dev.log().raw_frames,
        "every raw block"
    );
    let last = rows.last().unwrap();
    assert_eq!(&last[kind], "end");
    assert!(last[col(&rows[0], "detail")].contains("closed the connection"));
}

#[cfg(unix)]
#[test]
fn serial_port_that_hangs_up_is_an_error_and_the_record_is_kept() {
    use serialport::{SerialPort, TTYPort};
    use std::os::fd::AsRawFd;
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    let path = slave.name().expect("pty name");
    master
        .set_timeout(Duration::from_millis(20))
        .expect("timeout");
    let reader = master.try_clone_native().expect("clone");
    // Children must not inherit the device's end: a process holding it
    // open would keep the pty from hanging up.
    for fd in [master.as_raw_fd(), reader.as_raw_fd(), slave.as_raw_fd()] {
        // SAFETY: fcntl(F_SETFD) on descriptors this test owns.
        let r = unsafe { libc::fcntl(fd, libc::F_SETFD, libc::FD_CLOEXEC) };
        assert_eq!(r, 0, "fcntl");
    }
    let record = scratch("hangup.csv");
    // The monitor first, so that it reads the pty from the device's start.
    let child = Process::new(env!("CARGO_BIN_EXE_beamctl"))
        .args([
            "monitor",
            "--port",
            &path,
            "--baud",
            "921600",
            "--plain",
            "--record",
            s(&record),
            "--duration",
            "20",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run beamctl");
    let dev = std::thread::spawn(move || {
        let mut dev = FakeDevice::new(FakeConfig::default());
        let opts = ServeOptions {
            close_after: Some(Duration::from_millis(800)),
            ..ServeOptions::default()
        };
        dev.serve(reader, &mut master, &opts);
        // Dropping the master closes the pty: the board is unplugged.
        drop(master);
        dev
    });
    let o = child.wait_with_output().expect("wait");
    let dev = dev.join().expect("device");
    drop(slave);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains(&format!(
            "error: serial port {path} (921600 baud): the device disappeared"
        )),
        "{err}"
    );
    let rows = csv_rows(&record);
    let kind = col(&rows[0], "kind");
    let estimates = rows.iter().filter(|r| &r[kind] == "estimate").count() as u64;
    assert!(estimates > 20, "{estimates}");
    assert!(estimates <= dev.log().estimates);
    assert_eq!(stdout(&o).lines().count() as u64, estimates);
    assert_eq!(&rows.last().unwrap()[kind], "end");
    // The monitor asked for a status over the serial line, and got it.
    assert_eq!(dev.log().commands.len(), 1);
    assert!(err.contains("#0 status: accepted"), "{err}");
}

#[test]
fn another_protocol_version_stops_with_a_clear_error() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let server = std::thread::spawn(move || {
        let (mut stream, _) = listener.accept().unwrap();
        let mut dev = FakeDevice::new(FakeConfig::default());
        let mut out = vec![0u8];
        dev.advance(1_000, &mut out);
        // A frame of the next version (CRC good), then silence.
        let mut frame = [0u8; 64];
        let h = Header {
            version: beam_protocol::VERSION + 1,
            ..Header::new(Kind::Estimate, 11)
        };
        let n = encode_raw(&h, &[1, 2, 3], &mut frame).unwrap();
        out.extend_from_slice(&frame[..n]);
        stream.write_all(&out).unwrap();
        std::thread::sleep(Duration::from_secs(5));
    });
    let record = scratch("version.csv");
    let o = beamctl(&[
        "monitor",
        "--tcp",
        &addr,
        "--plain",
        "--record",
        s(&record),
        "--duration",
        "20",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains(
            "protocol version mismatch: the peer speaks version 4, this build 3; stopped without interpreting its frames"
        ),
        "{err}"
    );
    assert_eq!(stdout(&o).lines().count(), 10, "the v3 estimates before it");
    let rows = csv_rows(&record);
    let kind = col(&rows[0], "kind");
    assert!(rows
        .iter()
        .any(|r| &r[kind] == "error" && r[col(&rows[0], "detail")].contains("version mismatch")));
    drop(server);
}

#[test]
fn send_accepted_changes_only_what_is_given() {
    let (addr, dev) = fake_tcp(FakeConfig::default(), None);
    let o = beamctl(&["send", "--tcp", &addr, "excitation", "--amplitude", "0.2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).starts_with(
            "accepted: excitation --wave square --freq 7 --amplitude 0.2 --offset 0 (command seq 1"
        ),
        "{}",
        stdout(&o)
    );
    let dev = dev.join().unwrap();
    assert_eq!(
        dev.excitation(),
        &Excitation {
            amplitude_v: 0.2,
            ..Excitation::default()
        }
    );
    let cmds: Vec<Command> = dev.log().commands.iter().map(|c| c.1).collect();
    assert_eq!(cmds[0], Command::RequestStatus);
    assert_eq!(cmds.len(), 2);
}

/// `send estimator --output KIND` sets the sensor output kind and keeps
/// every other setting the device reports.
#[test]
fn send_estimator_output_sets_the_sensor_kind() {
    let (addr, dev) = fake_tcp(FakeConfig::default(), None);
    let o = beamctl(&["send", "--tcp", &addr, "estimator", "--output", "velocity"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).starts_with(
            "accepted: estimator --law adaptive --gain 10000 --forgetting-p 0.05 \
             --forgetting-h 0.05 --initial-gain 1000000000 --lambda 100 --output velocity"
        ),
        "{}",
        stdout(&o)
    );
    let dev = dev.join().unwrap();
    assert_eq!(
        dev.status().estimator.output,
        beam_protocol::OutputKind::Velocity
    );
}

#[test]
fn send_rejected_prints_the_reason_and_changes_nothing() {
    let (addr, dev) = fake_tcp(FakeConfig::default(), None);
    // Window [−1, 2] V: −1.5 V is outside; the host cannot know the
    // window, the device refuses.
    let o = beamctl(&["send", "--tcp", &addr, "excitation", "--amplitude", "1.5"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(
        stderr(&o).trim(),
        "error: the device rejected (3 SafeWindow): offset ± amplitude outside the piezo's safe window: excitation --wave square --freq 7 --amplitude 1.5 --offset 0 (command seq 1)"
    );
    let dev = dev.join().unwrap();
    assert_eq!(dev.excitation(), &Excitation::default());
}

#[test]
fn send_warns_when_the_local_check_expects_a_refusal_and_the_device_decides() {
    let (addr, dev) = fake_tcp(FakeConfig::default(), None);
    let o = beamctl(&["send", "--tcp", &addr, "excitation", "--freq", "6000"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 2, "{err}");
    assert!(
        lines[0].starts_with("warning: excitation: the local check expects a refusal (4 Frequency: frequency not in (0, Nyquist); device sample rate 10000 Hz"),
        "{err}"
    );
    assert!(
        lines[1].starts_with("error: the device rejected (4 Frequency)"),
        "{err}"
    );
    let dev = dev.join().unwrap();
    assert_eq!(dev.log().commands.len(), 2, "sent: the device decided");
    assert_eq!(dev.excitation(), &Excitation::default());
}

#[test]
fn send_without_an_answer_times_out() {
    let cfg = FakeConfig {
        answers_commands: false,
        ..FakeConfig::default()
    };
    let (addr, dev) = fake_tcp(cfg, None);
    let o = beamctl(&["send", "--tcp", &addr, "--timeout", "0.3", "freeze"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(
        stderr(&o).trim(),
        "error: no acknowledgement from the device within 0.3 s (command seq 0)"
    );
    let dev = dev.join().unwrap();
    assert_eq!(dev.log().commands.len(), 1, "received, not answered");
}

#[test]
fn send_status_prints_the_status() {
    let (addr, dev) = fake_tcp(FakeConfig::default(), None);
    let o = beamctl(&["send", "--tcp", &addr, "status"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.starts_with("accepted: status (command seq 0"), "{out}");
    for want in [
        "firmware 0.1.0, 2 mode(s), sample rate 10000 Hz",
        "excitation --wave square --freq 7 --amplitude 0.1 --offset 0",
        "estimator --law adaptive --gain 10000 --forgetting-p 0.05 --forgetting-h 0.05 --initial-gain 1000000000 --lambda 100 --output strain",
        "telemetry --estimates 100 --raw-decimation 0 --status 1",
        "commands accepted 1",
    ] {
        assert!(out.contains(want), "missing {want:?} in {out}");
    }
    dev.join().unwrap();
}

#[test]
fn monitor_sends_commands_from_stdin() {
    let (addr, dev) = fake_tcp(FakeConfig::default(), None);
    let record = scratch("stdin.csv");
    let mut child = Process::new(env!("CARGO_BIN_EXE_beamctl"))
        .args([
            "monitor",
            "--tcp",
            &addr,
            "--plain",
            "--stdin-commands",
            "--duration",
            "2",
            "--record",
            s(&record),
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Once an estimate is printed, the Status before it has arrived (the
    // fake device sends one at its start-up): unspecified settings are known.
    let mut out = std::io::BufReader::new(child.stdout.take().unwrap());
    let mut first = String::new();
    std::io::BufRead::read_line(&mut out, &mut first).unwrap();
    assert!(first.starts_with("sample="), "{first}");
    let mut stdin = child.stdin.take().unwrap();
    stdin
        .write_all(b"excitation --wave chirp --band 1:100 --sweep 10\nlaunch\ntelemetry --estimates 20000\n")
        .unwrap();
    drop(stdin);
    let drain = std::thread::spawn(move || std::io::copy(&mut out, &mut std::io::sink()));
    let o = child.wait_with_output().unwrap();
    drain.join().unwrap().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    for want in [
        "#1 excitation --wave chirp --band 1:100 --sweep 10 --amplitude 0.1 --offset 0: sent",
        "#1 excitation --wave chirp --band 1:100 --sweep 10 --amplitude 0.1 --offset 0: accepted",
        "'launch': ",
        "telemetry --estimates 20000 --raw-decimation 0 --status 1: the local check expects a refusal (13 Rate",
        "#2 telemetry --estimates 20000 --raw-decimation 0 --status 1: rejected (13 Rate)",
    ] {
        assert!(err.contains(want), "missing {want:?} in {err}");
    }
    let dev = dev.join().unwrap();
    assert!(matches!(dev.excitation().waveform, Waveform::Chirp { .. }));
    let rows = csv_rows(&record);
    let kind = col(&rows[0], "kind");
    let detail = col(&rows[0], "detail");
    assert!(rows
        .iter()
        .any(|r| &r[kind] == "command" && r[detail].starts_with("excitation --wave chirp")));
    assert_eq!(
        rows.iter()
            .filter(|r| &r[kind] == "ack" && &r[col(&rows[0], "result")] == "accepted")
            .count(),
        2
    );
}

#[test]
fn usage_errors_name_the_flag() {
    let o = beamctl(&["monitor", "--file", "/nonexistent/capture.bin", "--plain"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).starts_with("error: --file: cannot open /nonexistent/capture.bin"));
    let o = beamctl(&["monitor", "--tcp", "127.0.0.1:1", "--duration", "-1"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).starts_with("error: --duration: must be > 0"));
    let o = beamctl(&["monitor", "--plain"]);
    assert_eq!(o.status.code(), Some(2));
    let o = beamctl(&["monitor", "--tcp", "127.0.0.1:1", "--file", "x"]);
    assert_eq!(o.status.code(), Some(2));
    let o = beamctl(&["send", "--tcp", "127.0.0.1:1", "excitation", "--band", "5"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("expected LO:HI"), "{}", stderr(&o));
}

/// `beamctl selftest` against the fake device: the command acknowledged,
/// the report printed check by check with the Cramér–Rao bound for the
/// device's own estimate; `--json` carries the same; the device saw one
/// SelfTest command.
#[test]
fn selftest_prints_the_report_and_the_bound() {
    let (addr, dev) = fake_tcp(FakeConfig::default(), Some(Duration::from_secs(4)));
    let o = beamctl(&["selftest", "--tcp", &addr, "--duration", "5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    for want in [
        "every check passed",
        "adc_id         pass",
        "loopback       pass",
        "Cramér–Rao bound with the default excitation for 5 s",
        "ζ2",
    ] {
        assert!(out.contains(want), "{want}: {out}");
    }
    let dev = dev.join().unwrap();
    assert!(dev
        .log()
        .commands
        .iter()
        .any(|(_, c, _)| *c == beam_protocol::Command::SelfTest));

    let (addr, _dev) = fake_tcp(FakeConfig::default(), Some(Duration::from_secs(4)));
    let o = beamctl(&["selftest", "--tcp", &addr, "--duration", "2", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(doc["passed"], true);
    assert_eq!(doc["checks"][3][0], "loopback");
    assert_eq!(doc["report"]["loopback"]["expected_delay_samples"], 2.15);
    assert!(doc["crb"]["zeta"]["rel"][1].as_f64().unwrap() > 0.0);
}
