use std::sync::Arc;

use super::*;
use crate::protocol::Study;

/// The default study with fewer particles, for speed.
fn study() -> Arc<Study> {
    let mut s = Study::default_study();
    s.protocol.learning.particles = 300;
    Arc::new(s)
}

fn start(study: &Study, slot: usize, seed: u64) -> SessionStart {
    SessionStart {
        session_id: "test".into(),
        participant: "p-test".into(),
        protocol_name: study.protocol.name.clone(),
        protocol_sha256: study.sha256.clone(),
        seed,
        condition_order: condition_order(study, slot),
        program_labels: study.protocol.session.program_labels.clone(),
        software_version: "test".into(),
        pilot: true,
        slot,
        started_at: "2026-11-22T00:00:00Z".into(),
        simulated_truth: None,
        resumed_from: None,
        selection: None,
    }
}

fn session() -> Session {
    let s = study();
    let st = start(&s, 0, 7);
    Session::new(s, st).unwrap()
}

fn present(s: &mut Session) -> TrialView {
    let Prompt::Present(view) = s.prompt() else { panic!("expected a query to present, got {:?}", s.prompt()) };
    let id = s.query(view.query).query.id.clone();
    s.apply(&Event::QueryPresented { query: id }).unwrap();
    view
}

fn first_region(s: &Session, view: &TrialView) -> String {
    let q = s.query(view.query);
    s.study().object(q).regions[q.regions[0]].id.clone()
}

fn grasp_first(s: &mut Session) {
    let view = present(s);
    let r = first_region(s, &view);
    s.apply(&Event::GraspRecorded { region: r, measured: None }).unwrap();
}

#[test]
fn a_whole_session_runs_from_training_to_the_end() {
    let mut s = session();
    for _ in 0..26 {
        grasp_first(&mut s);
    }
    assert_eq!(s.trials().len(), 26);
    assert_eq!(s.trials().iter().filter(|t| t.phase == Phase::Training).count(), 10);
    let order = s.likert_order();
    assert_eq!(s.likert_count(), order.len());
    assert_eq!(order.len(), 8);
    for (k, &(program, item)) in order.iter().enumerate() {
        assert_eq!(s.prompt(), Prompt::Likert { program, item, index: k, total: 8 });
        let id = s.study().protocol.questionnaire.items[item].id.clone();
        s.apply(&Event::LikertAnswered { program, item: id, value: 4 }).unwrap();
    }
    assert_eq!(s.prompt(), Prompt::ForcedChoice);
    assert!(s.apply(&Event::Ended).is_err(), "the forced choice is still open");
    s.apply(&Event::ForcedChoice { program: 1 }).unwrap();
    assert_eq!(s.prompt(), Prompt::Finish);
    s.apply(&Event::Ended).unwrap();
    assert_eq!(s.prompt(), Prompt::Done { completed: true });
    assert!(s.apply(&Event::Note { text: "late".into() }).is_err());
}

#[test]
fn training_runs_follow_the_counterbalanced_order_and_test_is_shuffled() {
    let st = study();
    let a = Session::new(Arc::clone(&st), start(&st, 0, 1)).unwrap();
    let b = Session::new(Arc::clone(&st), start(&st, 1, 1)).unwrap();
    assert_eq!(a.learners()[0].condition, SelectorKind::Active);
    assert_eq!(b.learners()[0].condition, SelectorKind::Passive);
    let test_order = |seed| {
        let mut s = Session::new(Arc::clone(&st), start(&st, 0, seed)).unwrap();
        for _ in 0..10 {
            grasp_first(&mut s);
        }
        (0..16)
            .map(|_| {
                let v = present(&mut s);
                let r = first_region(&s, &v);
                s.apply(&Event::GraspRecorded { region: r, measured: None }).unwrap();
                match v.query {
                    QueryRef::Test(i) => i,
                    _ => panic!("a test query"),
                }
            })
            .collect::<Vec<_>>()
    };
    let (x, y) = (test_order(1), test_order(2));
    let mut sorted = x.clone();
    sorted.sort();
    assert_eq!(sorted, (0..16).collect::<Vec<_>>(), "every test query once");
    assert_ne!(x, y, "the order is shuffled per session seed");
    assert_eq!(x, test_order(1), "and reproducible");
}

#[test]
fn undo_restores_previous_belief() {
    let mut s = session();
    grasp_first(&mut s);
    let before = s.learners()[0].clone();
    let view = present(&mut s);
    assert!(!s.can_undo(), "presenting a query closes the undo window");
    let r = first_region(&s, &view);
    s.apply(&Event::GraspRecorded { region: r, measured: None }).unwrap();
    assert!(s.can_undo());
    s.apply(&Event::GraspUndone).unwrap();
    assert_eq!(s.learners()[0].belief, before.belief);
    assert_eq!(s.learners()[0].iteration, 1);
    assert_eq!(s.trials().len(), 1);
    assert!(matches!(s.prompt(), Prompt::Grasp(v) if v.trial == 2), "the same trial awaits its grasp again");
    assert!(s.apply(&Event::GraspUndone).is_err(), "only the last grasp");
}

#[test]
fn a_voided_trial_is_repeated_and_not_learned_from() {
    let mut s = session();
    let before = s.learners()[0].clone();
    let view = present(&mut s);
    s.apply(&Event::TrialVoided { reason: VoidReason::Dropped, detail: String::new() }).unwrap();
    assert_eq!(s.prompt(), Prompt::Present(view.clone()), "the same trial again");
    assert_eq!(s.learners()[0].belief, before.belief);
    // Voiding right after a grasp retracts it.
    let v = present(&mut s);
    let r = first_region(&s, &v);
    s.apply(&Event::GraspRecorded { region: r, measured: None }).unwrap();
    let applied = s.apply(&Event::TrialVoided { reason: VoidReason::RobotFault, detail: "slipped".into() }).unwrap();
    assert!(matches!(applied, Applied::Voided { retracted: true, .. }));
    assert_eq!(s.trials().len(), 0);
    assert_eq!(s.learners()[0].belief, before.belief);
    assert_eq!(s.prompt(), Prompt::Present(view));
}

#[test]
fn wrong_input_is_refused_and_changes_nothing() {
    let mut s = session();
    assert!(matches!(s.apply(&Event::QueryPresented { query: "nope".into() }), Err(SessionError::WrongQuery { .. })));
    assert!(
        s.apply(&Event::GraspRecorded { region: "left-grip".into(), measured: None }).is_err(),
        "nothing presented yet"
    );
    let view = present(&mut s);
    assert!(matches!(
        s.apply(&Event::GraspRecorded { region: "saddle".into(), measured: None }),
        Err(SessionError::UnknownRegion { .. })
    ));
    assert!(s.apply(&Event::LikertAnswered { program: 0, item: "prefer".into(), value: 3 }).is_err());
    assert!(s.apply(&Event::Resumed).is_err(), "not paused");
    assert_eq!(s.prompt(), Prompt::Grasp(view));
}

#[test]
fn pause_blocks_everything_but_notes_resume_and_abort() {
    let mut s = session();
    s.apply(&Event::Paused).unwrap();
    assert_eq!(s.prompt(), Prompt::Paused);
    let Prompt::Paused = s.prompt() else { unreachable!() };
    assert!(s.apply(&Event::QueryPresented { query: "bars-low-level".into() }).is_err());
    s.apply(&Event::Note { text: "participant needs water".into() }).unwrap();
    s.apply(&Event::Resumed).unwrap();
    assert!(matches!(s.prompt(), Prompt::Present(_)));
    s.apply(&Event::Aborted { reason: "fire alarm".into() }).unwrap();
    assert_eq!(s.prompt(), Prompt::Done { completed: false });
}

#[test]
fn the_same_events_give_the_same_state() {
    let run = || {
        let mut s = session();
        for _ in 0..6 {
            grasp_first(&mut s);
        }
        (s.learners()[0].belief.clone(), s.learners()[1].suggestion, s.trials().to_vec())
    };
    assert_eq!(run(), run());
}

#[test]
fn likert_values_must_be_on_the_scale() {
    let mut s = session();
    for _ in 0..26 {
        grasp_first(&mut s);
    }
    assert!(matches!(
        s.apply(&Event::LikertAnswered { program: 0, item: "prefer".into(), value: 9 }),
        Err(SessionError::OffScale { value: 9, min: 1, max: 5 })
    ));
    assert!(matches!(
        s.apply(&Event::LikertAnswered { program: 0, item: "nope".into(), value: 3 }),
        Err(SessionError::UnknownItem { .. })
    ));
    assert!(matches!(s.apply(&Event::ForcedChoice { program: 2 }), Err(SessionError::UnknownProgram(2))));
}

#[test]
fn region_observations_update_by_the_handle_taken() {
    let mut st = Study::default_study();
    st.protocol.learning.particles = 300;
    st.protocol.learning.observation = crate::protocol::ObservationModel::Region;
    let st = Arc::new(st);
    let mut s = Session::new(Arc::clone(&st), start(&st, 0, 3)).unwrap();
    let prior = s.learners()[0].belief.clone();
    grasp_first(&mut s);
    let after = &s.learners()[0].belief;
    assert_ne!(after, &prior, "the handle taken is evidence");
    assert!(after.weights().iter().all(|w| w.is_finite()));
    // The label model still maps the handle to a configuration for the log.
    let t = &s.trials()[0];
    assert_eq!(s.set(t.query).region_of(t.config), t.region);
}

fn measured_session(sigma_deg: f64) -> Session {
    let mut st = Study::default_study();
    st.protocol.learning.particles = 300;
    st.protocol.learning.observation = crate::protocol::ObservationModel::Measured;
    st.protocol.learning.measurement = Some(crate::protocol::MeasurementSpec {
        sigma_deg: vec![sigma_deg; 7],
        joint_names: crate::kinematics::JOINT_NAMES.iter().map(|n| n.to_string()).collect(),
        window_s: 0.5,
    });
    let st = Arc::new(st);
    Session::new(Arc::clone(&st), start(&st, 0, 3)).unwrap()
}

fn measurement(q_rad: Vec<f64>, offset_s: f64) -> ArmMeasurement {
    ArmMeasurement { q_rad, source: MeasurementSource::Simulated, offset_s }
}

/// The first offered region's id and its first configuration, and the last region's first
/// configuration, of the trial waiting for its grasp.
fn grips(s: &Session, view: &TrialView) -> (String, Vec<f64>, Vec<f64>) {
    let set = s.set(view.query);
    let last = set.regions().len() - 1;
    (
        first_region(s, view),
        set.configs().config(set.regions()[0].start),
        set.configs().config(set.regions()[last].start),
    )
}

#[test]
fn a_measured_grasp_updates_by_the_measured_likelihood() {
    let mut s = measured_session(5.0);
    let mut expected = s.learners()[0].clone();
    let view = present(&mut s);
    let (region, q, _) = grips(&s, &view);
    let set = s.set(view.query).clone();
    let m = measurement(q.iter().map(|v| v + 0.01).collect(), 0.1);
    s.apply(&Event::GraspRecorded { region, measured: Some(m.clone()) }).unwrap();
    let obs = crate::ergo::Observation::measured(set.configs(), &m.q_rad, &[5f64.to_radians(); 7]).unwrap();
    let QueryRef::Training(menu_index) = view.query else { panic!("training first") };
    let menu: Vec<FeasibleSet> = (0..s.study().training.len()).map(|i| s.set(QueryRef::Training(i)).clone()).collect();
    expected.learn(menu_index, &obs, &menu, s.context()).unwrap();
    assert_eq!(s.learners()[0].belief, expected.belief);
    let t = &s.trials()[0];
    let g = t.measured.as_ref().expect("recorded");
    assert_eq!((g.nearest, g.implied_region), (set.regions()[0].start, 0));
    assert!(g.agrees(t.region));
}

/// A session that learns from the measured arm scores its queries' measured outcomes and
/// says so in its start; one whose start says regions (a log of format 2) scores regions;
/// a start that claims measured selection for a protocol without a measured arm is refused.
#[test]
fn selection_scores_what_the_start_says_and_a_new_session_what_it_learns_from() {
    use crate::select::{OutcomeModel, Problem, menu_values};
    let s = measured_session(5.0);
    assert_eq!(s.start().selection, Some(SelectionOutcome::Measured));
    let menu: Vec<FeasibleSet> = (0..s.study().training.len()).map(|i| s.set(QueryRef::Training(i)).clone()).collect();
    let score = |outcomes| {
        menu_values(&Problem {
            belief: &s.learners()[0].belief,
            menu: &menu,
            alpha: s.context().alpha,
            outcomes,
            precision: Default::default(),
        })
    };
    let sigma = [5f64.to_radians(); 7];
    assert_eq!(s.learners()[0].scores, score(OutcomeModel::Measured { sigma: &sigma }));
    let mut old = s.start().clone();
    old.selection = Some(SelectionOutcome::Region);
    let replayed = Session::new(Arc::new(s.study().clone()), old).unwrap();
    assert_eq!(replayed.learners()[0].scores, score(OutcomeModel::Region));
    assert_ne!(replayed.learners()[0].scores, s.learners()[0].scores);
    let region = session();
    assert_eq!(region.start().selection, Some(SelectionOutcome::Region));
    let mut claimed = region.start().clone();
    claimed.selection = Some(SelectionOutcome::Measured);
    assert!(matches!(Session::new(Arc::new(region.study().clone()), claimed), Err(SessionError::BadStart(_))));
}

#[test]
fn a_measurement_that_implies_another_grip_is_flagged_and_the_key_kept() {
    let mut s = measured_session(2.0);
    let view = present(&mut s);
    let (region, _, other) = grips(&s, &view);
    s.apply(&Event::GraspRecorded { region, measured: Some(measurement(other, 0.0)) }).unwrap();
    let t = &s.trials()[0];
    let g = t.measured.as_ref().unwrap();
    assert_eq!(t.region, 0, "the operator's key is the record's region");
    assert_ne!(g.implied_region, 0);
    assert!(!g.agrees(t.region));
}

#[test]
fn a_grasp_without_a_measurement_learns_from_the_region() {
    let mut measured = measured_session(5.0);
    let mut region = {
        let mut st = measured.study().clone();
        st.protocol.learning.observation = crate::protocol::ObservationModel::Region;
        st.protocol.learning.measurement = None;
        let st = Arc::new(st);
        Session::new(Arc::clone(&st), start(&st, 0, 3)).unwrap()
    };
    grasp_first(&mut measured);
    grasp_first(&mut region);
    assert_eq!(measured.learners()[0].belief, region.learners()[0].belief, "the fallback is the region update");
    assert!(measured.trials()[0].measured.is_none());
}

#[test]
fn bad_measurements_are_refused_and_change_nothing() {
    let mut s = measured_session(5.0);
    let view = present(&mut s);
    let (region, q, _) = grips(&s, &view);
    let before = (s.trials().to_vec(), s.learners()[0].belief.clone(), s.prompt(), s.event_count());
    let state = |s: &Session| (s.trials().to_vec(), s.learners()[0].belief.clone(), s.prompt(), s.event_count());
    for (m, what) in [
        (measurement(q.clone(), 0.7), "offset_s"),
        (measurement(q[..6].to_vec(), 0.0), "q_rad"),
        (measurement(vec![f64::NAN; 7], 0.0), "q_rad"),
        (measurement(q.clone(), f64::INFINITY), "offset_s"),
    ] {
        let e = s.apply(&Event::GraspRecorded { region: region.clone(), measured: Some(m) }).unwrap_err();
        assert!(matches!(e, SessionError::BadMeasurement { .. }) && e.to_string().contains(what), "{e}");
        assert!(state(&s) == before, "unchanged after {e}");
    }
    // A protocol without measured observations expects none.
    let mut r = session();
    let view = present(&mut r);
    let region = first_region(&r, &view);
    let e = r.apply(&Event::GraspRecorded { region, measured: Some(measurement(q, 0.0)) }).unwrap_err();
    assert!(e.to_string().contains("expected no measurement"), "{e}");
}

#[test]
fn a_second_condition_shares_the_first_ones_scores_and_chooses_as_if_it_had_its_own() {
    let study = study();
    let s = Session::new(Arc::clone(&study), start(&study, 0, 21)).unwrap();
    let first = &s.learners()[0];
    for kind in SelectorKind::ALL {
        let rng = || SeededRng::seed_from_u64(5);
        let rngs = [SeededRng::seed_from_u64(4), rng()].into_iter();
        let both = Learner::first(&[first.condition, kind], first.belief.clone(), rngs, &s.menu, &s.ctx);
        let shared = &both[1];
        let own = Learner::new(kind, first.belief.clone(), rng(), &s.menu, &s.ctx);
        assert_eq!(format!("{:?}", shared.scores), format!("{:?}", own.scores), "{kind:?}");
        assert_eq!(shared.suggestion, own.suggestion, "{kind:?}");
        assert_eq!(shared.summary, own.summary, "{kind:?}");
        assert_eq!(shared.belief, own.belief, "{kind:?}");
    }
}

#[test]
fn a_void_reason_s_name_is_the_one_the_log_writes() {
    for r in VoidReason::ALL {
        assert_eq!(serde_json::to_value(r).unwrap(), serde_json::Value::from(r.name()), "{r:?}");
    }
}
