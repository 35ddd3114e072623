//! Any other robot: a program run for each command (`--robot-command PROGRAM`). It gets the
//! command as one line of JSON on standard input ([`super::RobotCommand`]); exit status 0
//! means the robot holds the object at the pose, any other status that it failed (its error
//! output is the detail). A program still running at the timeout is killed. Each program
//! runs in a process group of its own, and anything it started that is still running when
//! it exits is ended with it: a command leaves no processes behind.

use std::io::{Read, Write};
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::{Link, Report, RobotCommand, RobotSettings};
use crate::session::{RobotLinkKind, RobotState};

/// The most of a program's error output kept (its end).
const MAX_STDERR_BYTES: usize = 2000;

/// The program of the command under way: its process group while it runs (None once it
/// has ended and been waited for, so that a group id is never signalled after reuse).
type Running = Arc<Mutex<Option<i32>>>;

/// The program link.
pub struct CommandHook {
    program: PathBuf,
    reports: Sender<Report>,
    /// The command under way: set to abandon it (its end is not reported), and its program.
    abandon: Option<(Arc<AtomicBool>, Running)>,
}

impl CommandHook {
    /// Checks that `program` is a file that can be run.
    pub fn new(program: PathBuf, reports: Sender<Report>, _settings: &RobotSettings) -> Result<Self, String> {
        use std::os::unix::fs::PermissionsExt;
        let meta = std::fs::metadata(&program).map_err(|e| format!("{}: {e}", program.display()))?;
        if !meta.is_file() || meta.permissions().mode() & 0o111 == 0 {
            return Err(format!("{}: not an executable file", program.display()));
        }
        Ok(Self { program, reports, abandon: None })
    }
}

impl Link for CommandHook {
    fn kind(&self) -> RobotLinkKind {
        RobotLinkKind::Command
    }

    fn describe(&self) -> String {
        format!("command {}", self.program.display())
    }

    fn send(&mut self, command: &RobotCommand) -> Result<(), String> {
        self.cancel();
        let mut line = serde_json::to_vec(command).map_err(|e| e.to_string())?;
        line.push(b'\n');
        // Its own process group, so that a timeout kills whatever it started too.
        let mut child = Command::new(&self.program)
            .process_group(0)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| format!("cannot run {}: {e}", self.program.display()))?;
        // A program that does not read its input must not block the console: written from
        // the waiting thread, and a broken pipe is not an error.
        let stdin = child.stdin.take();
        let stderr = child.stderr.take();
        let abandon = Arc::new(AtomicBool::new(false));
        let running: Running = Arc::new(Mutex::new(i32::try_from(child.id()).ok()));
        self.abandon = Some((Arc::clone(&abandon), Arc::clone(&running)));
        let reports = self.reports.clone();
        let command = command.clone();
        std::thread::spawn(move || {
            if let Some(mut stdin) = stdin {
                std::thread::spawn(move || {
                    let _ = stdin.write_all(&line);
                });
            }
            let (err_tx, err_rx) = std::sync::mpsc::channel();
            std::thread::spawn(move || err_tx.send(stderr.map(read_tail).unwrap_or_default()));
            let status = wait(&mut child, &abandon);
            if let Ok(mut r) = running.lock() {
                *r = None;
            }
            // An abandoned command's end (its kill included) is not reported.
            let Some(status) = status.filter(|_| !abandon.load(Ordering::SeqCst)) else { return };
            // Something the program left running may hold its error output open: not waited for.
            let err = err_rx.recv_timeout(Duration::from_millis(500)).unwrap_or_default();
            let (state, detail) = match status.code() {
                Some(0) => (RobotState::AtPose, String::new()),
                Some(code) => (RobotState::Failed, with_stderr(format!("exit status {code}"), &err)),
                None => (RobotState::Failed, with_stderr("killed by a signal".into(), &err)),
            };
            let _ = reports.send(command.report(state, detail));
        });
        Ok(())
    }

    /// Kills the program under way and everything it started, now (the process may be
    /// about to exit), and leaves its end unreported.
    fn cancel(&mut self) {
        if let Some((abandon, running)) = self.abandon.take() {
            abandon.store(true, Ordering::SeqCst);
            if let Ok(r) = running.lock()
                && let Some(pid) = *r
            {
                kill_group(pid);
            }
        }
    }
}

impl Drop for CommandHook {
    fn drop(&mut self) {
        self.cancel();
    }
}

/// Waits for the program; kills it (and returns None) once the command is abandoned. When
/// it ends by itself, whatever it started and left running is ended with it: its process
/// group is killed while the program is still an unreaped zombie, so the group's id cannot
/// have been reused by then.
fn wait(child: &mut Child, abandon: &AtomicBool) -> Option<std::process::ExitStatus> {
    let pid = i32::try_from(child.id()).ok()?;
    loop {
        if abandon.load(Ordering::SeqCst) {
            kill_group(pid);
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        match has_exited(pid) {
            Ok(true) => {
                kill_group(pid);
                return child.wait().ok();
            }
            Ok(false) => std::thread::sleep(Duration::from_millis(10)),
            Err(_) => return None,
        }
    }
}

/// Whether the child `pid` has exited, without reaping it (`waitid` with `WNOWAIT`).
fn has_exited(pid: i32) -> std::io::Result<bool> {
    // SAFETY: a zeroed siginfo_t is a valid value for waitid(2) to fill; with WNOHANG its
    // si_pid stays 0 when the child has not changed state.
    unsafe {
        let mut info: libc::siginfo_t = std::mem::zeroed();
        let r = libc::waitid(libc::P_PID, pid as libc::id_t, &mut info, libc::WEXITED | libc::WNOHANG | libc::WNOWAIT);
        if r != 0 {
            return Err(std::io::Error::last_os_error());
        }
        Ok(info.si_pid() != 0)
    }
}

/// Kills everything in the process group the program leads.
fn kill_group(pid: i32) {
    // SAFETY: kill(2) with a negative pid signals a process group; no memory is involved.
    unsafe {
        libc::kill(-pid, libc::SIGKILL);
    }
}

/// The last [`MAX_STDERR_BYTES`] of a stream, read to its end.
fn read_tail(mut r: impl Read) -> String {
    let mut tail: Vec<u8> = Vec::new();
    let mut buf = [0u8; 4096];
    while let Ok(n) = r.read(&mut buf) {
        if n == 0 {
            break;
        }
        tail.extend_from_slice(&buf[..n]);
        if tail.len() > MAX_STDERR_BYTES {
            tail.drain(..tail.len() - MAX_STDERR_BYTES);
        }
    }
    String::from_utf8_lossy(&tail)
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect::<String>()
        .trim()
        .to_string()
}

fn with_stderr(what: String, err: &str) -> String {
    if err.is_empty() { what } else { format!("{what}: {err}") }
}
