//! The study's folders, resolved in one place (a study directory holding `participants/`
//! and `logs/`), and the advisory lock that allows one live session per participant.

use std::fs::File;
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

/// Where a study keeps its participant records and session logs.
#[derive(Clone, Debug, PartialEq)]
pub struct StudyDirs {
    /// The study directory (default: the current directory).
    pub root: PathBuf,
    pub participants: PathBuf,
    pub logs: PathBuf,
}

impl StudyDirs {
    /// `root/participants` and `root/logs`, unless given explicitly.
    pub fn resolve(root: Option<&Path>, participants: Option<&Path>, logs: Option<&Path>) -> Self {
        let root = root.map_or_else(|| PathBuf::from("."), Path::to_path_buf);
        Self {
            participants: participants.map_or_else(|| root.join("participants"), Path::to_path_buf),
            logs: logs.map_or_else(|| root.join("logs"), Path::to_path_buf),
            root,
        }
    }

    /// The study a log belongs to, from the log's own place: a log at
    /// `<study>/logs/<participant>/<file>.mcap` belongs to `<study>` (made absolute, no link
    /// followed), so that who withdrew is decided the same from any current folder. None for a
    /// log kept anywhere else.
    pub(crate) fn of_log(log: &Path, participant: &str) -> Option<Self> {
        let log = std::path::absolute(log).ok()?;
        let folder = log.parent()?;
        let logs = folder.parent()?;
        let study = logs.parent()?;
        (folder.file_name()? == participant && logs.file_name()? == "logs")
            .then(|| Self::resolve(Some(study), None, None))
    }

    /// The study folders for a log: the ones given (`--study-dir`, `--participants-dir`) if
    /// any, else the log's own study ([`Self::of_log`]), else the current folder's.
    pub fn for_log(root: Option<&Path>, participants: Option<&Path>, log: &Path, participant: &str) -> Self {
        if root.is_some() || participants.is_some() {
            return Self::resolve(root, participants, None);
        }
        Self::of_log(log, participant).unwrap_or_else(|| Self::resolve(None, None, None))
    }

    /// The flags that name these folders to another command (` --study-dir D`, and
    /// `--logs`/`--participants-dir` where they are not the study's own), empty for the
    /// current folder's study: what a printed command must carry to find the same study.
    pub fn flags(&self) -> String {
        let mut s = String::new();
        if self.root != Path::new(".") {
            s.push_str(&format!(" --study-dir {}", shell_word(&self.root.display().to_string())));
        }
        if self.logs != self.root.join("logs") {
            s.push_str(&format!(" --logs {}", shell_word(&self.logs.display().to_string())));
        }
        if self.participants != self.root.join("participants") {
            s.push_str(&format!(" --participants-dir {}", shell_word(&self.participants.display().to_string())));
        }
        s
    }

    /// The whole command that continues `participant`'s unfinished session in this study.
    pub fn resume_command(&self, participant: &str) -> String {
        format!("handover resume --participant {participant}{}", self.flags())
    }

    /// The folders that do not exist yet (a new study, or a typo in the path).
    pub fn missing(&self) -> Vec<&Path> {
        [self.participants.as_path(), self.logs.as_path()].into_iter().filter(|p| !p.is_dir()).collect()
    }

    /// A one-line description for screens and messages.
    pub fn describe(&self) -> String {
        let mut s = format!("participants {} · logs {}", self.participants.display(), self.logs.display());
        let missing = self.missing();
        if !missing.is_empty() {
            let names: Vec<String> = missing.iter().map(|p| p.display().to_string()).collect();
            s.push_str(&format!(" (new: {} will be created)", names.join(", ")));
        }
        s
    }
}

/// A path as one word of a shell command: as it is when it has nothing a shell would read,
/// else in single quotes.
pub fn shell_word(s: &str) -> String {
    if !s.is_empty() && s.bytes().all(|b| b.is_ascii_alphanumeric() || b"/._-+,:=@%".contains(&b)) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// How many times (10 ms apart) taking a held lock is tried again before it is refused.
const PROBE_RETRIES: u32 = 5;

/// Name of the lock file in a participant's log folder.
pub const LOCK_FILE: &str = ".session.lock";

/// Why a participant's lock was not taken.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error("participant '{participant}' already has a live session ({holder}); finish or quit it first")]
    Held { participant: String, holder: String },
    #[error("{path}: cannot lock the participant's session: {source}")]
    Io { path: PathBuf, source: std::io::Error },
}

/// One live session per participant: an advisory lock (flock) on `<logs dir>/.session.lock`,
/// held while the session runs and released on every exit, a crash or a kill included (the
/// operating system drops it with the process, so a lock never goes stale). The file says
/// who holds it.
#[derive(Debug)]
pub struct ParticipantLock {
    _file: File,
    pub path: PathBuf,
}

impl ParticipantLock {
    /// Takes the lock of the participant whose logs live in `dir` (created owner-only).
    pub fn acquire(dir: &Path, participant: &str, what: &str) -> Result<Self, LockError> {
        let path = dir.join(LOCK_FILE);
        let err = |source| LockError::Io { path: path.clone(), source };
        crate::private_files::create_dir(dir).map_err(err)?;
        let mut o = std::fs::OpenOptions::new();
        o.read(true).write(true).create(true).truncate(false);
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt;
            o.mode(0o600);
        }
        let mut file = o.open(&path).map_err(err)?;
        // A follower's probe (`holder_running`) holds a shared lock for microseconds: wait it out.
        let mut attempt = 0;
        let taken = loop {
            match file.try_lock() {
                Err(std::fs::TryLockError::WouldBlock) if attempt < PROBE_RETRIES => {
                    attempt += 1;
                    std::thread::sleep(std::time::Duration::from_millis(10));
                }
                other => break other,
            }
        };
        match taken {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                let mut holder = String::new();
                let _ = file.take(512).read_to_string(&mut holder);
                let holder = holder.trim();
                let holder = if holder.is_empty() { "held by another process".to_string() } else { holder.to_string() };
                return Err(LockError::Held { participant: participant.to_string(), holder });
            }
            Err(std::fs::TryLockError::Error(e)) => return Err(err(e)),
        }
        let note = format!(
            "{what} by process {} since {}",
            std::process::id(),
            chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Secs, true)
        );
        file.set_len(0).and_then(|()| file.rewind()).and_then(|()| file.write_all(note.as_bytes())).map_err(err)?;
        Ok(Self { _file: file, path })
    }
}

/// Whether a console (or a dry run) holds the session lock of the participant whose logs
/// live in `dir`: `Some(false)` once its holder has ended without a word (a crash, `kill -9`,
/// a power cut: the operating system dropped the lock), `None` when there is no lock file.
/// It asks the lock itself, with a shared lock taken and dropped at once (`acquire` waits out
/// such a probe), so it holds whichever process asks.
pub fn holder_running(dir: &Path) -> Option<bool> {
    let file = crate::input_file::open_regular(&dir.join(LOCK_FILE)).ok()?;
    match file.try_lock_shared() {
        Ok(()) => {
            let _ = file.unlock();
            Some(false)
        }
        Err(std::fs::TryLockError::WouldBlock) => Some(true),
        Err(std::fs::TryLockError::Error(_)) => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_session_of_a_participant_is_refused_and_told_who_holds_it() {
        let dir = std::env::temp_dir().join(format!("handover-lock-{}", std::process::id()));
        let first = ParticipantLock::acquire(&dir, "p-1", "console").unwrap();
        let e = ParticipantLock::acquire(&dir, "p-1", "console").unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("already has a live session") && msg.contains(&std::process::id().to_string()), "{msg}");
        assert_eq!(holder_running(&dir), Some(true), "this process holds it");
        drop(first);
        assert_eq!(holder_running(&dir), Some(false), "released");
        ParticipantLock::acquire(&dir, "p-1", "console").expect("released when dropped");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn folders_resolve_under_the_study_directory() {
        let d = StudyDirs::resolve(Some(Path::new("/data/study")), None, None);
        assert_eq!(d.logs, Path::new("/data/study/logs"));
        assert_eq!(d.participants, Path::new("/data/study/participants"));
        let d = StudyDirs::resolve(None, None, Some(Path::new("elsewhere")));
        assert_eq!((d.logs.as_path(), d.participants.as_path()), (Path::new("elsewhere"), Path::new("./participants")));
    }
}
