//! Learning ahead (the console's worker computes the learner after each grip while the
//! participant reaches) changes nothing in the log: the same session with and without it
//! writes the same file, byte for byte, and the responses did adopt what was computed ahead.

use std::path::Path;
use std::sync::Arc;

use handover::dryrun::plan_from;
use handover::protocol::Study;
use handover::record::RecordedSession;
use handover::session::{Session, Stamped};

const T0: u64 = 1_790_000_000_000_000_000;

/// How a run learns ahead.
#[derive(Clone, Copy, PartialEq)]
enum Ahead {
    Never,
    /// Every outcome before each key.
    Always,
    /// Interrupted after one outcome, then resumed: what was done is kept.
    Interrupted,
}

/// One scripted session logged at `path`: its bytes and how many responses adopted a
/// learner computed ahead.
fn session(path: &Path, ahead: Ahead, seed: u64) -> (Vec<u8>, usize) {
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 400.into();
    let text = v.to_string();
    let study = Arc::new(Study::from_json(&text, "small").unwrap());
    let p = plan_from(&study, &study.prior_population(), seed, 0, None, "2026-12-04T00:00:00Z".into());
    let session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
    let mut rec = RecordedSession::create(path, &text, session, T0).unwrap();
    let mut t = T0;
    while let Some(event) = p.participant.respond(rec.session()) {
        match ahead {
            Ahead::Never => {}
            Ahead::Always => assert!(rec.speculate(&mut || false)),
            Ahead::Interrupted => {
                let mut calls = 0;
                let mut stop = || {
                    calls += 1;
                    calls > 1
                };
                rec.speculate(&mut stop);
                assert!(rec.speculate(&mut || false));
            }
        }
        t += 1_000_000_000;
        rec.submit(Stamped { time_ns: t, event }).unwrap();
    }
    let adopted = rec.session().adopted_ahead();
    rec.finish().unwrap();
    (std::fs::read(path).unwrap(), adopted)
}

#[test]
fn learning_ahead_logs_the_same_bytes_and_is_adopted() {
    let dir = std::env::temp_dir().join(format!("handover-ahead-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for seed in [1, 2] {
        let (plain, none) = session(&dir.join(format!("plain-{seed}.mcap")), Ahead::Never, seed);
        assert_eq!(none, 0);
        for (name, ahead) in [("always", Ahead::Always), ("interrupted", Ahead::Interrupted)] {
            let (bytes, adopted) = session(&dir.join(format!("{name}-{seed}.mcap")), ahead, seed);
            assert!(bytes == plain, "seed {seed}: learning ahead ({name}) changed the log");
            // Every training response (5 per condition) adopted its learner.
            assert_eq!(adopted, 10, "seed {seed} ({name}): {adopted} responses adopted a learner computed ahead");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
