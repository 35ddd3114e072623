//! The operator console: ratatui screens, the pure key map, and one event loop generic over
//! the backend. The only module that uses ratatui and crossterm.

pub mod app;
pub mod keys;
mod screens;
pub mod theme;

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use ratatui::Terminal;
use ratatui::backend::Backend;
use ratatui::crossterm::event::{self, Event as TermEvent};

pub use app::{App, AppConfig};
pub use screens::render;

/// The signals that end the console as a quit does (the terminal restored, the session
/// left resumable), with exit status 128 + the signal's number.
pub const TERMINATING_SIGNALS: [i32; 3] =
    [signal_hook::consts::SIGTERM, signal_hook::consts::SIGHUP, signal_hook::consts::SIGINT];

/// How the console ended.
#[derive(Debug, Default)]
pub struct Outcome {
    /// Printed after the terminal is restored.
    pub message: Option<String>,
    /// The signal that ended it, if one did.
    pub signal: Option<i32>,
}

/// The loop: draw, wait for a key (or a tick), update; until the app quits or a signal
/// arrives (`signal` holds its number, 0 for none). Generic over the backend so the same
/// loop runs on a terminal or a test backend.
pub fn run_loop<B: Backend>(terminal: &mut Terminal<B>, app: &mut App, signal: &AtomicUsize) -> Result<(), String>
where
    B::Error: std::fmt::Display,
{
    while !app.quit {
        if signal.load(Ordering::SeqCst) != 0 {
            app.interrupt();
            break;
        }
        app.tick(crate::dryrun::now_ns());
        let size = terminal.size().map_err(|e| e.to_string())?;
        app.visible = size.width >= theme::MIN_WIDTH && size.height >= theme::MIN_HEIGHT;
        terminal.draw(|f| render(app, f)).map_err(|e| e.to_string())?;
        let ready = match event::poll(Duration::from_millis(50)) {
            Ok(ready) => ready,
            // A signal can interrupt the wait; it is handled at the top of the loop.
            Err(_) if signal.load(Ordering::SeqCst) != 0 => continue,
            Err(e) => return Err(e.to_string()),
        };
        if ready {
            match event::read() {
                Ok(TermEvent::Key(k)) => app.key(k),
                Ok(_) => {}
                Err(_) if signal.load(Ordering::SeqCst) != 0 => continue,
                Err(e) => return Err(e.to_string()),
            }
        }
    }
    Ok(())
}

/// Runs the console on the real terminal; the terminal is restored on every exit path: a
/// quit, an error, a panic (ratatui's hook) and SIGTERM, SIGHUP or SIGINT (which end the
/// session as a quit does, resumable).
pub fn run_terminal(mut app: App) -> Result<Outcome, String> {
    let signal = Arc::new(AtomicUsize::new(0));
    for sig in TERMINATING_SIGNALS {
        signal_hook::flag::register_usize(sig, Arc::clone(&signal), sig as usize).map_err(|e| e.to_string())?;
    }
    let mut terminal = ratatui::init();
    let result = run_loop(&mut terminal, &mut app, &signal);
    ratatui::restore();
    let caught = signal.load(Ordering::SeqCst);
    result.map(|()| Outcome { message: app.exit_message.take(), signal: (caught != 0).then_some(caught as i32) })
}
