//! The one long-lived thread that owns the recorded session while the console runs: every
//! event is applied and made durable there, off the drawing loop, in the order submitted.

use std::path::PathBuf;
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, TryRecvError, channel};
use std::thread::JoinHandle;
use std::time::Duration;

use super::app::SummaryView;
use crate::analysis::analyse;
use crate::record::{RecordError, RecordedSession, SubmitError, read_log};
use crate::session::{Event, Session, Stamped};

/// What the console asks of the worker.
enum Job {
    Submit(Stamped),
    /// The session is over: finish the log and analyse it for the summary screen.
    Finish {
        completed: bool,
    },
    /// The console quits: finish the log (the session stays resumable if unfinished).
    Close,
}

/// Why a submitted event did not take effect.
#[derive(Debug)]
pub enum Failure {
    /// The session refused it (nothing was logged).
    Rejected(String),
    /// The log could not be written; the event is kept to be retried.
    Log { message: String, last_event: usize, event: Box<Stamped> },
}

/// What the worker reports.
pub enum Done {
    /// An event was applied and logged (or not): the session as it now is, and the event.
    Submitted(Box<Session>, Result<Event, Failure>),
    Finished(Box<SummaryView>),
    /// The log was finished at a quit: its path, or why it could not be finished.
    Closed {
        path: PathBuf,
        error: Option<String>,
    },
}

/// The worker thread and its two channels.
pub struct Worker {
    jobs: Sender<Job>,
    done: Receiver<Done>,
    /// Jobs sent and not yet reported.
    outstanding: usize,
    path: PathBuf,
    thread: Option<JoinHandle<()>>,
}

impl Worker {
    /// Starts the thread that owns `rec` from now on.
    pub fn spawn(mut rec: RecordedSession) -> Self {
        let (jobs, job_rx) = channel::<Job>();
        let (done_tx, done) = channel::<Done>();
        let path = rec.path().to_path_buf();
        let thread = std::thread::spawn(move || {
            // A job that arrived while the worker was learning ahead.
            let mut waiting: Option<Job> = None;
            loop {
                let job = match waiting.take() {
                    Some(job) => job,
                    None => match job_rx.recv() {
                        Ok(job) => job,
                        Err(_) => return,
                    },
                };
                match job {
                    Job::Submit(stamped) => {
                        let result = submit(&mut rec, stamped);
                        let session = Box::new(rec.session().clone());
                        if done_tx.send(Done::Submitted(session, result)).is_err() {
                            return;
                        }
                        // Idle until the next key: learn ahead for the query presented (if
                        // any), and leave off as soon as a job comes.
                        let mut stop = || match job_rx.try_recv() {
                            Ok(job) => {
                                waiting = Some(job);
                                true
                            }
                            Err(TryRecvError::Empty) => false,
                            Err(TryRecvError::Disconnected) => true,
                        };
                        rec.speculate(&mut stop);
                    }
                    Job::Finish { completed } => {
                        let _ = done_tx.send(Done::Finished(Box::new(finish(rec, completed))));
                        return;
                    }
                    Job::Close => {
                        let path = rec.path().to_path_buf();
                        let error = rec.finish().err().map(|e| e.to_string());
                        let _ = done_tx.send(Done::Closed { path, error });
                        return;
                    }
                }
            }
        });
        Self { jobs, done, outstanding: 0, path, thread: Some(thread) }
    }

    /// The log being written.
    pub fn path(&self) -> &PathBuf {
        &self.path
    }

    /// Whether a job is under way.
    pub fn busy(&self) -> bool {
        self.outstanding > 0
    }

    /// Jobs sent and not yet reported.
    pub fn outstanding(&self) -> usize {
        self.outstanding
    }

    fn send(&mut self, job: Job) {
        if self.jobs.send(job).is_ok() {
            self.outstanding += 1;
        }
    }

    pub fn submit(&mut self, stamped: Stamped) {
        self.send(Job::Submit(stamped));
    }

    pub fn finish(&mut self, completed: bool) {
        self.send(Job::Finish { completed });
    }

    pub fn close(&mut self) {
        self.send(Job::Close);
    }

    /// A report, if one is ready or comes within `wait` while a job is under way
    /// (`Duration::MAX`: until it comes). `Err` when the thread is gone with work outstanding.
    pub fn poll(&mut self, wait: Duration) -> Result<Option<Done>, &'static str> {
        if self.outstanding == 0 {
            return Ok(None);
        }
        let got = if wait.is_zero() {
            self.done.try_recv().map_err(|e| e == TryRecvError::Disconnected)
        } else {
            self.done.recv_timeout(wait).map_err(|e| e == RecvTimeoutError::Disconnected)
        };
        match got {
            Ok(done) => {
                self.outstanding -= 1;
                Ok(Some(done))
            }
            Err(false) => Ok(None),
            Err(true) => {
                self.outstanding = 0;
                Err("internal error: the worker stopped")
            }
        }
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        // Closing the job channel ends the thread after its current job.
        let (dead, _) = channel();
        self.jobs = dead;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn submit(rec: &mut RecordedSession, stamped: Stamped) -> Result<Event, Failure> {
    rec.submit(stamped.clone()).map(|_| stamped.event.clone()).map_err(|e| match e {
        SubmitError::Rejected(e) => Failure::Rejected(e.to_string()),
        SubmitError::Log(e) => {
            let last_event = match &e {
                RecordError::Write { last_event, .. } => *last_event,
                _ => rec.session().event_count(),
            };
            Failure::Log { message: e.to_string(), last_event, event: Box::new(stamped) }
        }
    })
}

fn finish(rec: RecordedSession, completed: bool) -> SummaryView {
    match rec.finish() {
        Ok(path) => {
            let analysis =
                read_log(&path).map_err(|e| e.to_string()).and_then(|l| analyse(&l).map_err(|e| e.to_string()));
            let (analysis, error) = match analysis {
                Ok(a) => (Some(a), None),
                Err(e) => (None, Some(e)),
            };
            SummaryView { log_path: path, completed, analysis, error }
        }
        Err(e) => SummaryView { log_path: PathBuf::new(), completed, analysis: None, error: Some(e.to_string()) },
    }
}
