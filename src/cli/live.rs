//! The live view option shared by `run`, `dry-run` and `resume`.

use std::net::SocketAddr;

use anyhow::Result;
use clap::Args;
use handover::live::{DEFAULT_ADDR, LiveView};

/// Serve the session to Foxglove while it runs.
#[derive(Debug, Clone, Default, Args)]
pub struct LiveArgs {
    /// Serve the session's topics to Foxglove while it runs (the Foxglove WebSocket protocol;
    /// the same 3D scene, plots and notes as the log), on ADDR: 127.0.0.1:8765 (this machine
    /// only) when given without one; 0.0.0.0:8765 lets other machines connect. In Foxglove:
    /// Open connection → Foxglove WebSocket → ws://ADDR.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = DEFAULT_ADDR)]
    pub live: Option<SocketAddr>,
}

impl LiveArgs {
    /// The live view, serving; none without --live.
    pub fn start(&self) -> Result<Option<LiveView>> {
        let Some(addr) = self.live else { return Ok(None) };
        let view = LiveView::start(addr).map_err(anyhow::Error::msg)?;
        errln!("live view: {} (Foxglove: Open connection → Foxglove WebSocket)", view.url());
        Ok(Some(view))
    }
}
