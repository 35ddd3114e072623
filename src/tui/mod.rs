//! The operator console: ratatui screens, the pure key map, and one event loop generic over
//! the backend. The only module that uses ratatui and crossterm.

pub mod app;
pub mod keys;
mod screens;
pub mod theme;

use std::time::Duration;

use ratatui::Terminal;
use ratatui::backend::Backend;
use ratatui::crossterm::event::{self, Event as TermEvent};

pub use app::{App, AppConfig};
pub use screens::render;

/// The loop: draw, wait for a key (or a tick), update; until the app quits. Generic over
/// the backend so the same loop runs on a terminal or a test backend.
pub fn run_loop<B: Backend>(terminal: &mut Terminal<B>, app: &mut App) -> Result<(), String>
where
    B::Error: std::fmt::Display,
{
    while !app.quit {
        app.tick(crate::dryrun::now_ns());
        terminal.draw(|f| render(app, f)).map_err(|e| e.to_string())?;
        if event::poll(Duration::from_millis(50)).map_err(|e| e.to_string())? {
            match event::read().map_err(|e| e.to_string())? {
                TermEvent::Key(k) => app.key(k),
                TermEvent::Resize(_, _) => {}
                _ => {}
            }
        }
    }
    Ok(())
}

/// Runs the console on the real terminal; the terminal is restored on every exit path
/// (ratatui's init installs a panic hook that restores it too).
pub fn run_terminal(mut app: App) -> Result<Option<String>, String> {
    let mut terminal = ratatui::init();
    let result = run_loop(&mut terminal, &mut app);
    ratatui::restore();
    result.map(|()| app.exit_message.take())
}
