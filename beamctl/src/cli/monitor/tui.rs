//! The terminal view (ratatui + crossterm).
//!
//! ```text
//!  beamctl monitor │ TCP 127.0.0.1:4000 │ fw 0.1.0 │ 2 modes │ 10000 Hz │ square --freq 7, 0.1 V, offset 0 V
//! ┌Estimate──────────────────────────────┐┌Link────────────────────────────────┐
//! │mode  ω̂ (rad/s)     ζ̂          b̂̄       ││frames/s 101.0     bytes/s 8.3 kB/s │
//! │1     39.1533       0.0207     9.6293  ││frames   1234      lost (gaps) 0    │
//! │2     245.3711      0.13       16.1458 ││CRC 0  framing 0  oversize 0  …     │
//! │λmin(P) 0.0025  adaptive  t 12.34 s    ││device: overruns 0 · ADC crc 0 …    │
//! │EXCITED CONVERGED PHYSICALLY_VALID     ││                                    │
//! └──────────────────────────────────────┘└────────────────────────────────────┘
//! ┌ω̂1 (rad/s), last 60 s─────────────────┐┌ζ̂1, last 60 s──────────────────────┐
//! │ ω̂1 vs device time (braille line)      ││ ζ̂1 vs device time                  │
//! └──────────────────────────────────────┘└────────────────────────────────────┘
//! ┌ω̂2 (rad/s), last 60 s─────────────────┐┌ζ̂2, last 60 s──────────────────────┐
//! │ … one row of charts per mode           ││                                    │
//! └──────────────────────────────────────┘└────────────────────────────────────┘
//! ┌Commands──────────────────────────────────────────────────────────────────────┐
//! │#1 excitation --wave square --freq 7 --amplitude 0.2 --offset 0: accepted     │
//! │> telemetry --raw-decimation 2█                                               │
//! └──────────────────────────────────────────────────────────────────────────────┘
//!  q quit · : command · f freeze · r resume · s status
//! ```
//!
//! Keys: `q` (or Esc, Ctrl-C) quits; `:` opens the command line, where any
//! `beamctl send` command is typed (`excitation --amplitude 0.2`,
//! `estimator --gain 2e4`, `reset`, …), Enter sends, Esc closes; `f`, `r` and `s` send
//! freeze, resume and a status request.

use super::event::{Event, KeyAction};
use super::state::State;
use crate::link::grammar::{self, CommandArgs};
use crate::link::text;
use beam_protocol::{StatusFlags, MAX_MODES};
use ratatui::crossterm::event::{self as ct, KeyCode, KeyEventKind, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Style, Stylize};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Axis, Block, Chart, Dataset, GraphType, Paragraph};
use ratatui::Frame;
use std::sync::mpsc::SyncSender;
use std::time::Instant;

/// Device time shown by the charts (s).
pub const CHART_WINDOW_S: f64 = 60.0;
/// Most points per chart line.
const CHART_POINTS: usize = 600;
/// Colours of modes 1, 2, 3.
const MODE_COLORS: [Color; MAX_MODES] = [Color::Cyan, Color::Magenta, Color::Yellow];

/// Read keys on a thread and send them to the event loop.
pub fn spawn_keys(tx: SyncSender<Event>) {
    std::thread::spawn(move || loop {
        match ct::read() {
            Ok(ct::Event::Key(k)) if k.kind != KeyEventKind::Release => {
                if tx.send(Event::Key(k)).is_err() {
                    break;
                }
            }
            Ok(_) => {}
            Err(_) => break,
        }
    });
}

/// Handle a key.
pub fn key(st: &mut State, k: ct::KeyEvent) -> KeyAction {
    if k.modifiers.contains(KeyModifiers::CONTROL) && k.code == KeyCode::Char('c') {
        return KeyAction::Quit;
    }
    if let Some(input) = st.input.as_mut() {
        match k.code {
            KeyCode::Esc => st.input = None,
            KeyCode::Backspace => {
                input.pop();
            }
            KeyCode::Enter => {
                let line = st.input.take().unwrap_or_default();
                let line = line.trim();
                if line.is_empty() {
                    return KeyAction::None;
                }
                return match grammar::parse_line(line) {
                    Ok(c) => KeyAction::Send(c),
                    Err(m) => {
                        st.log(format!("'{line}': {m}"));
                        KeyAction::None
                    }
                };
            }
            KeyCode::Char(c) => input.push(c),
            _ => {}
        }
        return KeyAction::None;
    }
    match k.code {
        KeyCode::Char('q') | KeyCode::Esc => KeyAction::Quit,
        KeyCode::Char(':') => {
            st.input = Some(String::new());
            KeyAction::None
        }
        KeyCode::Char('f') => KeyAction::Send(CommandArgs::Freeze),
        KeyCode::Char('r') => KeyAction::Send(CommandArgs::Resume),
        KeyCode::Char('s') => KeyAction::Send(CommandArgs::Status),
        _ => KeyAction::None,
    }
}

/// Draw the whole view.
pub fn draw(f: &mut Frame<'_>, st: &State, now: Instant) {
    let modes = st.modes().max(1);
    let [title, top, charts, commands, help] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Length(6 + modes as u16),
        Constraint::Min(6),
        Constraint::Length(7),
        Constraint::Length(1),
    ])
    .areas(f.area());
    f.render_widget(Paragraph::new(title_line(st)).bold(), title);
    let [est, link] =
        Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(top);
    f.render_widget(estimate_pane(st, now, modes), est);
    f.render_widget(link_pane(st, now), link);
    let [w, z] =
        Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(charts);
    let rows = Layout::vertical(vec![Constraint::Ratio(1, modes as u32); modes]);
    for (i, (wa, za)) in rows.split(w).iter().zip(rows.split(z).iter()).enumerate() {
        chart(f, *wa, st, i, &format!("ω̂{} (rad/s)", i + 1), |p, i| {
            p.omega[i]
        });
        chart(f, *za, st, i, &format!("ζ̂{}", i + 1), |p, i| p.zeta[i]);
    }
    f.render_widget(command_pane(st, commands), commands);
    let keys = if st.writable {
        " q quit · : command (e.g. excitation --amplitude 0.2) · f freeze · r resume · s status"
    } else {
        " q quit · (commands disabled: read-only source or --listen-only)"
    };
    f.render_widget(Paragraph::new(keys).dim(), help);
}

fn title_line(st: &State) -> String {
    let mut parts = vec!["beamctl monitor".to_string(), st.source.clone()];
    if let Some(s) = st.host.status() {
        let fw = s.firmware;
        parts.push(format!("fw {}.{}.{}", fw.major, fw.minor, fw.patch));
        parts.push(format!("{} modes", s.modes));
        parts.push(format!("{} Hz", s.sample_rate_hz));
        let e = &s.excitation;
        let flags = grammar::waveform_flags(&e.waveform);
        parts.push(format!(
            "{}{}{}, {} V, offset {} V",
            e.waveform.kind().name(),
            if flags.is_empty() { "" } else { " " },
            flags,
            e.amplitude_v,
            e.offset_v
        ));
        if s.adaptation_frozen {
            parts.push("FROZEN".into());
        }
    } else {
        parts.push("no Status yet".into());
    }
    format!(" {}", parts.join(" │ "))
}

fn flag_style(f: StatusFlags) -> Style {
    let bad = [
        StatusFlags::SENSOR_FAULT,
        StatusFlags::ADC_SATURATED,
        StatusFlags::DAC_SATURATED,
        StatusFlags::TELEMETRY_DROPPED,
        StatusFlags::STATE_DEGRADED,
    ];
    let held = [
        StatusFlags::FROZEN_BY_COMMAND,
        StatusFlags::FROZEN_AUTO,
        StatusFlags::INPUT_GONE,
        StatusFlags::CHANGE_DETECTED,
        StatusFlags::SENSOR_LEVEL,
    ];
    if bad.contains(&f) {
        Style::new().fg(Color::Red).bold()
    } else if held.contains(&f) {
        Style::new().fg(Color::Yellow)
    } else {
        Style::new().fg(Color::Green)
    }
}

fn estimate_pane(st: &State, now: Instant, modes: usize) -> Paragraph<'static> {
    let block = Block::bordered().title("Estimate");
    let Some((e, at)) = &st.last else {
        return Paragraph::new("waiting for the first estimate…").block(block);
    };
    let mut lines = vec![Line::from(format!(
        "{:<5} {:<14} {:<12} {:<12}",
        "mode", "ω̂ (rad/s)", "ζ̂", "b̂̄"
    ))
    .bold()];
    for i in 0..modes {
        let row = match e.modes.get(i) {
            Some(m) => format!(
                "{:<5} {:<14} {:<12} {:<12}",
                i + 1,
                m.omega_rad_s,
                m.zeta,
                m.b_bar
            ),
            None => format!("{:<5} {:<14} {:<12} {:<12}", i + 1, "-", "-", "-"),
        };
        lines.push(Line::from(row).fg(MODE_COLORS[i % MAX_MODES]));
    }
    let t = st.host.time_s(e.sample_index).map_or_else(
        || format!("sample {}", e.sample_index),
        |t| format!("t {t:.3} s"),
    );
    let level = e
        .excitation_level
        .map_or_else(|| "-".to_string(), |l| format!("{l:.3e}"));
    lines.push(Line::from(format!(
        "λ {} rad/s   λmin(P)/tr(P) {level}   law {}   {t}   ({:.1} s ago)",
        e.lambda_rad_s,
        e.estimator.name(),
        now.duration_since(*at).as_secs_f64()
    )));
    let mut flags: Vec<Span> = text::FLAG_NAMES
        .iter()
        .filter(|(f, _)| e.flags.contains(*f))
        .map(|(f, n)| Span::styled(format!("{n} "), flag_style(*f)))
        .collect();
    if flags.is_empty() {
        flags.push(Span::raw("no flags"));
    }
    lines.push(Line::from(flags));
    lines.push(match st.live.last() {
        Some((_, v)) if v.trusted => Line::from(format!(
            "trusted: yes (over the last {} s)",
            st.live.window_s()
        ))
        .fg(Color::Green),
        Some((_, v)) => Line::from(format!("trusted: {}", v.summary())).fg(Color::Red),
        None => Line::from("trusted: not judged yet").dim(),
    });
    Paragraph::new(lines).block(block)
}

fn count(label: &str, n: u64) -> Span<'static> {
    let s = format!("{label} {n}  ");
    if n > 0 {
        Span::styled(s, Style::new().fg(Color::Red).bold())
    } else {
        Span::raw(s)
    }
}

fn link_pane(st: &State, now: Instant) -> Paragraph<'static> {
    let c = st.host.counters();
    let (fps, bps) = st.host.rates(now);
    let mut lines = vec![
        Line::from(format!(
            "frames/s {fps:<8.1} bytes/s {:.1} kB/s   frames {}",
            bps / 1e3,
            c.frames_ok
        )),
        Line::from(vec![
            count("lost (seq gaps)", c.lost),
            count("CRC", c.crc_errors),
            count("framing", c.framing_errors),
        ]),
        Line::from(vec![
            count("oversize", c.oversize),
            count("malformed", c.malformed),
            count("dup", c.duplicates),
            count("out of order", c.out_of_order),
        ]),
    ];
    match st.host.status() {
        Some(s) => {
            let d = &s.counters;
            lines.push(Line::from(vec![
                Span::raw("device: "),
                count("overruns", u64::from(d.overruns)),
                count("tlm dropped", u64::from(d.telemetry_dropped)),
                count("rejected", u64::from(d.rejected_samples)),
                count("rx err", u64::from(d.rx_frame_errors)),
            ]));
            lines.push(Line::from(vec![
                Span::raw("ADC "),
                count("crc", u64::from(d.adc_crc_errors)),
                count("status", u64::from(d.adc_status_errors)),
                count("stuck", u64::from(d.adc_stuck)),
                count("sat", u64::from(d.adc_saturations)),
                count("DAC sat", u64::from(d.dac_saturations)),
                Span::raw(format!(
                    "cmds ok/rej {}/{}",
                    d.commands_accepted, d.commands_rejected
                )),
            ]));
        }
        None => lines.push(Line::from("device: no Status yet")),
    }
    Paragraph::new(lines).block(Block::bordered().title("Link"))
}

/// Points of mode `i` in the chart window, at most [`CHART_POINTS`].
fn series(
    st: &State,
    i: usize,
    value: &dyn Fn(&super::state::Point, usize) -> f64,
) -> (Vec<(f64, f64)>, f64) {
    let Some(fs) = st.host.sample_rate_hz() else {
        return (Vec::new(), 0.0);
    };
    let t_end = st
        .history
        .last()
        .map_or(0.0, |p| p.sample_index as f64 / fs);
    let t0 = t_end - CHART_WINDOW_S;
    let start = st
        .history
        .iter()
        .rposition(|p| (p.sample_index as f64 / fs) < t0)
        .map_or(0, |k| k + 1);
    let window = st.history.get(start..).unwrap_or_default();
    let stride = window.len().div_ceil(CHART_POINTS).max(1);
    let pts = window
        .iter()
        .step_by(stride)
        .map(|p| (p.sample_index as f64 / fs, value(p, i)))
        .filter(|(_, v)| v.is_finite())
        .collect();
    (pts, t_end)
}

fn chart(
    f: &mut Frame<'_>,
    area: Rect,
    st: &State,
    i: usize,
    label: &str,
    value: impl Fn(&super::state::Point, usize) -> f64,
) {
    let block = Block::bordered().title(format!("{label}, last {CHART_WINDOW_S:.0} s"));
    let (pts, t_end) = series(st, i, &value);
    let (lo, hi) = pts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    if !lo.is_finite() {
        f.render_widget(Paragraph::new("no data yet").block(block), area);
        return;
    }
    let pad = ((hi - lo) * 0.05)
        .max(hi.abs().max(lo.abs()) * 1e-6)
        .max(1e-12);
    let (lo, hi) = (lo - pad, hi + pad);
    let t0 = (t_end - CHART_WINDOW_S).max(0.0);
    let data = Dataset::default()
        .marker(Marker::Braille)
        .graph_type(GraphType::Line)
        .style(Style::new().fg(MODE_COLORS[i % MAX_MODES]))
        .data(&pts);
    let fmt = |v: f64| format!("{v:.5}");
    let chart = Chart::new(vec![data])
        .block(block)
        .x_axis(
            Axis::default()
                .bounds([t0, t_end.max(t0 + 1e-9)])
                .labels([format!("{t0:.1} s"), format!("{t_end:.1} s")]),
        )
        .y_axis(
            Axis::default()
                .bounds([lo, hi])
                .labels([fmt(lo), fmt(0.5 * (lo + hi)), fmt(hi)]),
        );
    f.render_widget(chart, area);
}

fn command_pane(st: &State, area: Rect) -> Paragraph<'static> {
    let rows = usize::from(area.height.saturating_sub(3));
    let skip = st.log.len().saturating_sub(rows);
    let mut lines: Vec<Line> = st
        .log
        .iter()
        .skip(skip)
        .map(|l| Line::from(l.clone()))
        .collect();
    lines.push(match &st.input {
        Some(s) => Line::from(format!("> {s}█")).bold(),
        None if st.writable => Line::from("press : to type a command").dim(),
        None => Line::from("").dim(),
    });
    Paragraph::new(lines).block(Block::bordered().title("Commands"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::fake::{FakeConfig, FakeDevice};
    use crate::link::Host;
    use ratatui::backend::TestBackend;
    use ratatui::Terminal;

    /// A state fed with 2 s of the fake device, and the screen it draws.
    fn screen() -> (String, State) {
        let mut dev = FakeDevice::new(FakeConfig::default());
        let mut bytes = Vec::new();
        dev.advance(20_000, &mut bytes);
        let now = Instant::now();
        let mut st = State::new("TCP test:1".into(), Host::new(false), true, 10.0);
        for f in st.host.receive(&bytes, now).into_iter().flatten() {
            st.frame(&f, now);
        }
        st.log("#1 freeze: accepted".into());
        let mut term = Terminal::new(TestBackend::new(120, 36)).unwrap();
        term.draw(|f| draw(f, &st, now)).unwrap();
        let buf = term.backend().buffer().clone();
        let text: String = (0..buf.area.height)
            .map(|y| {
                (0..buf.area.width)
                    .map(|x| buf[(x, y)].symbol().to_string())
                    .collect::<String>()
                    + "\n"
            })
            .collect();
        (text, st)
    }

    #[test]
    fn the_view_shows_estimates_link_and_commands() {
        let (s, st) = screen();
        let (e, _) = st.last.as_ref().unwrap();
        assert_eq!(e.sample_index, 19_999);
        for want in [
            "TCP test:1",
            "fw 0.1.0",
            "10000 Hz",
            "square --freq 7, 0.1 V",
            "Estimate",
            &e.modes[0].omega_rad_s.to_string(),
            &e.modes[1].zeta.to_string(),
            "EXCITED",
            "PHYSICALLY_VALID",
            "Link",
            "frames 202",
            "lost (seq gaps) 0",
            "ω̂1 (rad/s), last 60 s",
            "ζ̂2, last 60 s",
            "#1 freeze: accepted",
            "press : to type a command",
        ] {
            assert!(s.contains(want), "missing {want:?} in\n{s}");
        }
    }

    #[test]
    fn keys_open_the_command_line_and_send() {
        let (_, mut st) = screen();
        let press = |st: &mut State, c: KeyCode| key(st, ct::KeyEvent::new(c, KeyModifiers::NONE));
        assert!(matches!(
            press(&mut st, KeyCode::Char('f')),
            KeyAction::Send(CommandArgs::Freeze)
        ));
        assert!(matches!(
            press(&mut st, KeyCode::Char(':')),
            KeyAction::None
        ));
        for c in "resett".chars() {
            press(&mut st, KeyCode::Char(c));
        }
        press(&mut st, KeyCode::Backspace);
        assert_eq!(st.input.as_deref(), Some("reset"));
        assert!(matches!(
            press(&mut st, KeyCode::Enter),
            KeyAction::Send(CommandArgs::Reset)
        ));
        assert!(st.input.is_none());
        press(&mut st, KeyCode::Char(':'));
        for c in "bogus".chars() {
            press(&mut st, KeyCode::Char(c));
        }
        assert!(matches!(press(&mut st, KeyCode::Enter), KeyAction::None));
        assert!(st.log.back().unwrap().starts_with("'bogus':"));
        assert!(matches!(
            press(&mut st, KeyCode::Char('q')),
            KeyAction::Quit
        ));
    }
}
