//! The operator console: ratatui screens, the one key table, the update, the worker that owns
//! the recorded session, and one event loop generic over
//! the backend. The only module that uses ratatui and crossterm.

pub mod app;
mod driver;
pub mod follow;
pub mod keys;
mod screens;
pub mod theme;
mod update;
mod worker;

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use ratatui::Terminal;
use ratatui::backend::Backend;

use crate::record;
use ratatui::crossterm::event::{self, Event as TermEvent};

pub use app::{App, AppConfig};
pub use screens::render;

/// The signals that end the console as a quit does (the terminal restored, the session
/// left resumable), with exit status 128 + the signal's number: every signal whose default
/// action ends the process and that a program may catch, so none of them leaves the terminal
/// on the alternate screen without echo. (SIGKILL cannot be caught: after `kill -9`, type
/// `reset`.)
pub(crate) const TERMINATING_SIGNALS: [i32; 7] = [
    signal_hook::consts::SIGTERM,
    signal_hook::consts::SIGHUP,
    signal_hook::consts::SIGINT,
    signal_hook::consts::SIGQUIT,
    signal_hook::consts::SIGUSR1,
    signal_hook::consts::SIGUSR2,
    signal_hook::consts::SIGALRM,
];

/// How the console ended.
#[derive(Debug, Default)]
pub struct Outcome {
    /// Printed after the terminal is restored.
    pub message: Option<String>,
    /// The signal that ended it, if one did.
    pub signal: Option<i32>,
}

/// The loop: draw, wait for a key (or a tick), update; until the app quits or `stop` names
/// a signal to stop for (then the app leaves as a quit does). Generic over the backend so
/// the same loop runs on a terminal or a test backend.
pub(crate) fn run_loop<B: Backend>(
    terminal: &mut Terminal<B>,
    app: &mut App,
    stop: &dyn Fn() -> Option<i32>,
) -> Result<Option<i32>, String>
where
    B::Error: std::fmt::Display,
{
    while !app.quit {
        if let Some(sig) = stop() {
            app.interrupt();
            return Ok(Some(sig));
        }
        app.tick(crate::dryrun::now_ns());
        let size = terminal.size().map_err(|e| e.to_string())?;
        app.visible = size.width >= theme::MIN_WIDTH && size.height >= theme::MIN_HEIGHT;
        terminal.draw(|f| render(app, f)).map_err(|e| e.to_string())?;
        // Wait for a key or the tick. While the worker has an event in hand, its report ends
        // the wait too (looked for every 2 ms), so the next screen is drawn as soon as it is
        // there rather than at the tick.
        let tick = Instant::now() + TICK;
        let ready = loop {
            let left = tick.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break false;
            }
            let busy = app.busy();
            match event::poll(if busy { left.min(Duration::from_millis(2)) } else { left }) {
                Ok(true) => break true,
                Ok(false) if busy && app.collect_reports() => break false,
                Ok(false) => {}
                // A signal can interrupt the wait; it is handled at the top of the loop.
                Err(_) if stop().is_some() => break false,
                Err(e) => return Err(e.to_string()),
            }
        };
        if ready {
            match event::read() {
                Ok(TermEvent::Key(k)) => {
                    app.key(k);
                    // Most keys' work is done in a few milliseconds (a grip learned ahead):
                    // its screen is then the next drawn, with no "computing" frame before it.
                    if app.busy() {
                        app.await_reports(KEY_WAIT);
                    }
                }
                Ok(_) => {}
                Err(_) if stop().is_some() => continue,
                Err(e) => return Err(e.to_string()),
            }
        }
    }
    Ok(None)
}

/// The loop's tick: the screen is redrawn at least this often (clocks, robot reports).
const TICK: Duration = Duration::from_millis(50);

/// How long a key's work is waited for before the screen shows it under way: half a frame.
const KEY_WAIT: Duration = Duration::from_millis(8);

/// How long the loop has to leave by itself after a signal or a vanished terminal.
const WATCHDOG_GRACE: Duration = Duration::from_secs(3);

/// Ends the process if the loop cannot: crossterm's `event::poll` never returns once the
/// terminal is gone (crossterm-rs/crossterm#793: its reader retries a read that returns 0
/// forever), which would leave the console spinning with its signal unanswered. Every
/// acknowledged event is already on disk, so leaving without the log's summary loses
/// nothing: the log replays and `handover resume` continues it.
fn watchdog(stop: impl Fn() -> Option<i32> + Send + 'static) {
    std::thread::spawn(move || {
        loop {
            std::thread::sleep(Duration::from_millis(200));
            if let Some(sig) = stop() {
                std::thread::sleep(WATCHDOG_GRACE);
                ratatui::restore();
                eprintln!("handover: stopped by signal {sig}; every event recorded is on disk; resume the session");
                std::process::exit(128 + sig);
            }
        }
    });
}

/// Runs the console on the real terminal; the terminal is restored on every exit path: a
/// quit, an error, a panic (ratatui's hook), any of [`TERMINATING_SIGNALS`], and a terminal that
/// goes away without a signal (treated as SIGHUP); each ends the session as a quit does,
/// resumable.
pub fn run_terminal(mut app: App) -> Result<Outcome, String> {
    let signal = on_terminal(|terminal, stop| run_loop(terminal, &mut app, stop))?;
    Ok(Outcome { message: app.exit_message.take(), signal })
}

/// Runs `body` on the real terminal with the console's signal handling (the signals, a
/// vanished terminal, the watchdog) and restores the terminal however it ends.
fn on_terminal<T>(
    body: impl FnOnce(&mut ratatui::DefaultTerminal, &dyn Fn() -> Option<i32>) -> Result<T, String>,
) -> Result<T, String> {
    let signal = Arc::new(AtomicUsize::new(0));
    for sig in TERMINATING_SIGNALS {
        signal_hook::flag::register_usize(sig, Arc::clone(&signal), sig as usize).map_err(|e| e.to_string())?;
    }
    let stop = {
        let signal = Arc::clone(&signal);
        move || -> Option<i32> {
            use std::io::IsTerminal;
            match signal.load(Ordering::SeqCst) {
                0 if !std::io::stdin().is_terminal() => Some(signal_hook::consts::SIGHUP),
                0 => None,
                sig => Some(sig as i32),
            }
        }
    };
    watchdog(stop.clone());
    let mut terminal = ratatui::init();
    let result = body(&mut terminal, &stop);
    ratatui::restore();
    result
}

/// `handover follow`: the log followed on the real terminal until q, Esc or a signal (the
/// signal's number is returned); nothing is written.
pub fn run_follow(follower: record::Follower) -> Result<Option<i32>, String> {
    let mut view = follow::FollowView::new(follower);
    on_terminal(|terminal, stop| {
        loop {
            if let Some(sig) = stop() {
                return Ok(Some(sig));
            }
            view.tick(crate::dryrun::now_ns());
            terminal.draw(|f| follow::render(&view, f)).map_err(|e| e.to_string())?;
            let ready = match event::poll(follow::POLL) {
                Ok(ready) => ready,
                Err(_) if stop().is_some() => continue,
                Err(e) => return Err(e.to_string()),
            };
            if ready {
                match event::read() {
                    Ok(TermEvent::Key(k)) if follow::quits(k) => return Ok(None),
                    Ok(_) => {}
                    Err(_) if stop().is_some() => continue,
                    Err(e) => return Err(e.to_string()),
                }
            }
        }
    })
}
