//! The live view on a terminal, drawn with ratatui: the header as text, then per signal its
//! label, a sparkline across the window and its range.

use super::{columns, View};
use ratatui::crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
use ratatui::layout::{Constraint, Layout};
use ratatui::widgets::{Paragraph, Sparkline};
use ratatui::Frame;
use std::time::Duration;

/// Width of a row's label (`{name:>3} {now:+8.2} {unit:<3} `).
const LABEL: u16 = 17;
/// Width of a row's range (`[lo … hi]`).
const RANGE: u16 = 22;

pub fn draw(frame: &mut Frame, view: &View, device: &str) {
    let header = view.header(device);
    if view.last.is_none() {
        frame.render_widget(Paragraph::new(header.join("\n")), frame.area());
        return;
    }
    let rows: Vec<_> = view.rows().collect();
    let mut heights = vec![Constraint::Length(header.len() as u16 + 1)];
    heights.extend(rows.iter().map(|_| Constraint::Length(1)));
    heights.push(Constraint::Min(0));
    let areas = Layout::vertical(heights).split(frame.area());
    frame.render_widget(Paragraph::new(header.join("\n")), areas[0]);
    for (row, &area) in rows.iter().zip(&areas[1..]) {
        let [label, plot, range] = Layout::horizontal([
            Constraint::Length(LABEL),
            Constraint::Min(1),
            Constraint::Length(RANGE),
        ])
        .areas(area);
        frame.render_widget(Paragraph::new(row.label()), label);
        // one bar per column of the plot, 0..=100 over the window's range
        let data = columns(row.history, plot.width as usize, 100);
        frame.render_widget(Sparkline::default().data(&data).max(100), plot);
        frame.render_widget(Paragraph::new(format!(" {}", row.range())), range);
    }
}

/// In raw mode Ctrl-C is a key, not a signal: it, `q` and Esc stop the view.
pub fn stop_key_pressed() -> std::io::Result<bool> {
    while event::poll(Duration::ZERO)? {
        if let Event::Key(k) = event::read()? {
            let ctrl_c =
                k.code == KeyCode::Char('c') && k.modifiers.contains(KeyModifiers::CONTROL);
            if k.kind == KeyEventKind::Press
                && (ctrl_c || matches!(k.code, KeyCode::Char('q') | KeyCode::Esc))
            {
                return Ok(true);
            }
        }
    }
    Ok(false)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::watch::tests::sample;
    use ratatui::backend::TestBackend;
    use ratatui::Terminal;

    fn screen(view: &View, width: u16, height: u16) -> Vec<String> {
        let mut t = Terminal::new(TestBackend::new(width, height)).unwrap();
        t.draw(|f| draw(f, view, "tcp://x:1")).unwrap();
        let buf = t.backend().buffer().clone();
        (0..height)
            .map(|y| {
                (0..width)
                    .map(|x| buf[(x, y)].symbol().to_string())
                    .collect()
            })
            .collect()
    }

    #[test]
    fn the_screen_shows_the_header_labels_ranges_and_a_rising_plot() {
        let mut v = View::new(5.0);
        for s in 0..200 {
            v.push(&sample(s, s as f32 * 0.1));
        }
        let lines = screen(&v, 100, 20);
        let text = lines.join("\n");
        assert!(text.contains("state armed   mode joint"), "{text}");
        let a1 = lines
            .iter()
            .find(|l| l.trim_start().starts_with("α1"))
            .unwrap();
        assert!(
            a1.contains("+19.90") && a1.contains("[+0.00 … +19.90]"),
            "{a1}"
        );
        // a ramp: the plot starts empty (the window's minimum) and ends full
        let plot: String = a1
            .chars()
            .skip(LABEL as usize)
            .take(100 - (LABEL + RANGE) as usize)
            .collect();
        let plot: Vec<char> = plot.trim_end().chars().collect();
        assert_eq!((plot[0], plot[plot.len() - 1]), (' ', '█'), "{a1}");
        assert!(plot.len() > 40, "{a1}");
    }

    #[test]
    fn before_any_telemetry_it_says_so() {
        let text = screen(&View::new(5.0), 60, 10).join("\n");
        assert!(text.contains("waiting for telemetry"), "{text}");
    }
}
