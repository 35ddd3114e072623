//! Progress of a long run where no terminal shows the bar: when standard error is not a
//! terminal (a batch job's log), a plain line every `HANDOVER_PROGRESS_S` seconds (60 by
//! default) says how far the bar has come.

use std::io::IsTerminal as _;
use std::time::{Duration, Instant};

use indicatif::ProgressBar;

/// The one progress bar of a long run: `NAME [====>   ] pos/len UNIT, elapsed, ETA`, on
/// standard error; where no terminal shows it, a plain line every interval instead
/// ([`lines_when_batch`]).
pub fn bar(name: &str, len: u64, unit: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    // Braces in a name or unit would be read as template keys: they are left out.
    let plain = |s: &str| s.replace(['{', '}'], "");
    let template =
        format!("{} [{{bar:40}}] {{pos}}/{{len}} {}, {{elapsed}} elapsed, ETA {{eta}}", plain(name), plain(unit));
    if let Ok(style) = indicatif::ProgressStyle::with_template(&template) {
        bar.set_style(style.progress_chars("=> "));
    }
    lines_when_batch(&bar, name);
    bar
}

/// The worker threads of a run (`--threads`, else every core), and their number.
pub fn worker_pool(threads: Option<usize>) -> anyhow::Result<(rayon::ThreadPool, usize)> {
    use anyhow::Context as _;
    let threads = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().context("cannot start worker threads")?;
    Ok((pool, threads))
}

/// The interval of progress lines, from `HANDOVER_PROGRESS_S` (0.1 s to a day), else 60 s.
fn interval() -> Duration {
    std::env::var("HANDOVER_PROGRESS_S")
        .ok()
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && (0.1..=86_400.0).contains(s))
        .map_or(Duration::from_secs(60), Duration::from_secs_f64)
}

/// A duration as `1 h 02 min`, `3 min 05 s` or `12 s`.
fn human(d: Duration) -> String {
    let s = d.as_secs();
    match (s / 3600, s / 60 % 60, s % 60) {
        (0, 0, s) => format!("{s} s"),
        (0, m, s) => format!("{m} min {s:02} s"),
        (h, m, _) => format!("{h} h {m:02} min"),
    }
}

/// When standard error is not a terminal, prints `name: pos/len (p %), … elapsed, about …
/// left` every interval until `bar` is finished or dropped.
pub fn lines_when_batch(bar: &ProgressBar, name: &str) {
    if std::io::stderr().is_terminal() {
        return;
    }
    let (weak, name, every) = (bar.downgrade(), name.to_string(), interval());
    std::thread::spawn(move || {
        let mut next = Instant::now() + every;
        loop {
            std::thread::sleep(Duration::from_millis(50).min(every));
            let Some(bar) = weak.upgrade() else { return };
            if bar.is_finished() {
                return;
            }
            if Instant::now() < next {
                continue;
            }
            next += every;
            let (pos, len) = (bar.position(), bar.length().unwrap_or(0));
            let percent = if len == 0 { 0.0 } else { 100.0 * pos as f64 / len as f64 };
            let left = if pos == 0 { "unknown".to_string() } else { format!("about {}", human(bar.eta())) };
            eprintln!("{name}: {pos}/{len} ({percent:.0} %), {} elapsed, {left} left", human(bar.elapsed()));
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_read_as_people_say_them() {
        assert_eq!(human(Duration::from_secs(12)), "12 s");
        assert_eq!(human(Duration::from_secs(185)), "3 min 05 s");
        assert_eq!(human(Duration::from_secs(3720)), "1 h 02 min");
    }
}
