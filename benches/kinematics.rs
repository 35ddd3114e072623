//! IK enumeration for one hand pose, and the feasible set of one handlebar query.
//!
//! cargo bench --bench kinematics

use criterion::{Criterion, criterion_group, criterion_main};
use handover::kinematics::{HumanArm, feasible_set, swivel_grid};
use handover::protocol::Study;

fn ik_enumerate_hand_pose(c: &mut Criterion) {
    let arm = HumanArm::from_height(1.75).unwrap();
    let q = [0.5, 0.2, 0.3, 1.4, 0.2, 0.1, -0.1];
    let grasp = arm.forward(&q).hand;
    let swivels = swivel_grid(5f64.to_radians());
    c.bench_function("ik_enumerate_hand_pose", |b| b.iter(|| arm.inverse(&grasp, &swivels).len()));
}

fn feasible_set_handlebar_query(c: &mut Criterion) {
    let study = Study::default_study();
    let q = study.query("bars-low-level").unwrap();
    let object = study.object(q);
    let pose = q.query.pose.to_isometry();
    let disc = study.protocol.discretisation;
    c.bench_function("feasible_set_handlebar_query", |b| {
        b.iter(|| feasible_set(&study.arm, object, &pose, &q.regions, &disc).configs.len())
    });
}

criterion_group!(benches, ik_enumerate_hand_pose, feasible_set_handlebar_query);
criterion_main!(benches);
