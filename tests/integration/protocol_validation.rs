//! Protocol files: the default is valid and complete; every kind of bad input is reported
//! with the field's path and what was expected.

use handover::protocol::{DEFAULT_PROTOCOL, Study};
use serde_json::{Value, json};

fn default_json() -> Value {
    serde_json::from_str(DEFAULT_PROTOCOL).unwrap()
}

fn problems(v: &Value) -> String {
    match Study::from_json(&v.to_string(), "test.json") {
        Ok(_) => panic!("accepted: {v}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn default_protocol_is_the_paper_study() {
    let s = Study::default_study();
    assert!((s.arm.upper_arm - 0.186 * 1.75).abs() < 1e-12);
    let count =
        |list: &[handover::protocol::ResolvedQuery], obj: &str| list.iter().filter(|q| q.query.object == obj).count();
    assert_eq!((count(&s.training, "handlebars"), count(&s.training, "u-lock")), (4, 4));
    assert_eq!((count(&s.test, "handlebars"), count(&s.test, "u-lock")), (8, 8));
    for q in s.all_queries() {
        assert_eq!(q.regions.len(), 2, "{}", q.query.id);
        assert!(q.feasible.per_region.iter().all(|&n| n > 0), "{}: {:?}", q.query.id, q.feasible.per_region);
        // Plausible handover positions: in front of the person, below the shoulder, within reach.
        let [x, y, z] = q.query.pose.position;
        assert!((0.25..=0.5).contains(&x) && (-0.2..=0.2).contains(&y) && (-0.45..=0.0).contains(&z), "{}", q.query.id);
    }
    // Varied in height, distance and orientation.
    let distinct = |f: &dyn Fn(&handover::protocol::ResolvedQuery) -> i64| {
        let mut v: Vec<i64> = s.all_queries().map(f).collect();
        v.sort();
        v.dedup();
        v.len()
    };
    assert!(distinct(&|q| (q.query.pose.position[2] * 100.0) as i64) >= 4);
    assert!(distinct(&|q| (q.query.pose.position[0] * 100.0) as i64) >= 3);
    assert!(distinct(&|q| (q.query.pose.rpy_deg.iter().sum::<f64>()) as i64) >= 5);
}

#[test]
fn handlebars_spread_wider_than_the_lock() {
    // The handlebars' grips are far apart: their regions lie far apart in configuration
    // space; the lock's two grips are close together.
    let s = Study::default_study();
    let gap = |id: &str| {
        let q = s.query(id).unwrap();
        let mean = |r: usize| {
            let cs: Vec<_> = q.feasible.configs.iter().filter(|c| c.region == r).collect();
            (0..7).map(|d| cs.iter().map(|c| c.q[d]).sum::<f64>() / cs.len() as f64).collect::<Vec<_>>()
        };
        let (a, b) = (mean(0), mean(1));
        a.iter().zip(&b).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt()
    };
    for (bars, lock) in [("bars-low-level", "lock-low-upright"), ("bars-waist-tilted", "lock-chest-tilted")] {
        assert!(gap(bars) > 2.0 * gap(lock), "{bars} {} vs {lock} {}", gap(bars), gap(lock));
    }
}

#[test]
fn every_bad_input_names_its_field() {
    type Edit = Box<dyn Fn(&mut Value)>;
    let cases: Vec<(Edit, &str)> = vec![
        (Box::new(|v| v.as_object_mut().unwrap().remove("name").map(|_| ()).unwrap()), "missing field `name`"),
        (Box::new(|v| v["training_menu"][0]["pose"]["position"] = json!("here")), "training_menu[0].pose.position"),
        (
            Box::new(|v| v["training_menu"][1]["object"] = json!("bicycle")),
            "training_menu[1].object: unknown object 'bicycle'",
        ),
        (
            Box::new(|v| v["training_menu"][0]["regions"] = json!(["saddle"])),
            "training_menu[0].regions[0]: unknown region 'saddle'",
        ),
        (Box::new(|v| v["training_menu"][0]["regions"] = json!([])), "training_menu[0].regions: is empty"),
        (
            Box::new(|v| v["test_set"][3]["id"] = json!("bars-low-level")),
            "test_set[3].id: duplicate id 'bars-low-level'",
        ),
        (Box::new(|v| v["objects"][1]["id"] = json!("handlebars")), "objects[1].id: duplicate id"),
        (
            Box::new(|v| v["objects"][0]["regions"][1]["id"] = json!("left-grip")),
            "objects[0].regions[1].id: duplicate id",
        ),
        (
            Box::new(|v| v["objects"][0]["regions"][0]["tsr"]["Bw"][2] = json!([0.1, -0.1])),
            "objects[0].regions[0].tsr.Bw[2]",
        ),
        (
            Box::new(|v| v["arm"]["limits_deg"] = json!([[0, 1], [0, 1], [0, 1], [150, 0], [0, 1], [0, 1], [0, 1]])),
            "arm.limits_deg[3]",
        ),
        (Box::new(|v| v["arm"]["body_height_m"] = json!(7.0)), "arm.body_height_m"),
        (Box::new(|v| v["arm"] = json!({})), "arm: expected body_height_m"),
        (
            Box::new(|v| v["arm"]["side"] = json!("both")),
            "arm.side: unknown variant `both`, expected `right` or `left`",
        ),
        (
            Box::new(|v| v["pose_scaling"]["reference_body_height_m"] = json!(0.1)),
            "pose_scaling.reference_body_height_m: body height 0.1 m is outside",
        ),
        (
            Box::new(|v| v["pose_scaling"] = json!({"reference": 1.75})),
            "pose_scaling.reference: unknown field `reference`, expected `reference_body_height_m`",
        ),
        (
            Box::new(|v| v["training_menu"][0]["pose"]["position"] = json!([2.0, 0.0, 0.0])),
            "training_menu[0].pose: region 'left-grip'",
        ),
        (Box::new(|v| v["discretisation"]["swivel_step_deg"] = json!(-5)), "discretisation.swivel_step_deg"),
        (Box::new(|v| v["training_menu"] = json!([])), "training_menu: is empty"),
        (Box::new(|v| v["objects"][0]["colour"] = json!("red")), "unknown field `colour`"),
        (Box::new(|v| v["learning"]["particles"] = json!(-5)), "learning.particles"),
        (Box::new(|v| v["learning"]["particles"] = json!(0)), "learning.particles: is 0"),
        (Box::new(|v| v["learning"]["alpha"] = json!(0)), "learning.alpha"),
        (
            Box::new(|v| v["learning"]["prior"]["q_star_deg"][2] = json!({"kind": "uniform", "min": 5, "max": -5})),
            "learning.prior.q_star_deg[2]: min 5 must be below max -5",
        ),
        (Box::new(|v| v["learning"]["prior"]["w"] = json!([])), "learning.prior.w: has 0 entries, expected 7"),
        (Box::new(|v| v["learning"]["learn"] = json!("elbows")), "learning.learn"),
        (Box::new(|v| v["learning"]["label_model"]["w"][0] = json!(-1)), "learning.label_model.w[0]"),
        (
            Box::new(|v| v["learning"]["resampling"] = json!({"kind": "ess-below", "fraction": 2})),
            "learning.resampling.fraction",
        ),
        (Box::new(|v| v["learning"]["moves"] = json!(51)), "learning.moves: is 51, expected 0 to 50"),
    ];
    for (edit, needle) in cases {
        let mut v = default_json();
        edit(&mut v);
        let msg = problems(&v);
        assert!(msg.contains(needle), "expected '{needle}' in:\n{msg}");
        assert!(msg.starts_with("test.json: invalid protocol"), "{msg}");
    }
}

#[test]
fn all_problems_are_reported_at_once() {
    let mut v = default_json();
    v["training_menu"][1]["object"] = json!("bicycle");
    v["test_set"][0]["regions"] = json!(["saddle"]);
    let msg = problems(&v);
    assert!(msg.contains("(2 problems)"), "{msg}");
}

#[test]
fn text_that_is_not_json_is_refused() {
    let e = Study::from_json("{ not json", "x.json").unwrap_err().to_string();
    assert!(e.starts_with("x.json: invalid protocol"), "{e}");
}

/// Issue 13's bar: every height from 1.50 to 1.95 m with either hand is served by the default
/// protocol, every grip of every query reachable; a left arm's feasible sets are the right
/// arm's mirror images, angle for angle; the poses scale with the reach and the left
/// poses are the right ones mirrored.
#[test]
fn the_default_protocol_serves_every_body_with_either_hand() {
    use handover::kinematics::Hand;
    use handover::protocol::{Body, for_body};
    for cm in (150..=195).step_by(5) {
        let h = f64::from(cm) / 100.0;
        let (_, right) = for_body(DEFAULT_PROTOCOL, "default", Body { height_m: Some(h), hand: Hand::Right })
            .unwrap_or_else(|e| panic!("{h} m right: {e}"));
        let (text, left) = for_body(DEFAULT_PROTOCOL, "default", Body { height_m: Some(h), hand: Hand::Left })
            .unwrap_or_else(|e| panic!("{h} m left: {e}"));
        assert!(text.contains("\"side\":\"left\""), "the text as run says which arm");
        let scale = right.arm.reach() / (0.186 + 0.146 + 0.4 * 0.108) / 1.75;
        assert!((right.pose_scale() - h / 1.75).abs() < 1e-12 && (scale - h / 1.75).abs() < 1e-12);
        for (r, l) in right.all_queries().zip(left.all_queries()) {
            let id = &r.query.id;
            assert!(r.feasible.per_region.iter().all(|&n| n > 0), "{h} m right {id}: {:?}", r.feasible.per_region);
            assert_eq!(r.feasible.per_region, l.feasible.per_region, "{h} m {id}");
            // The same configurations, enumerated in another order.
            let sorted = |s: &handover::kinematics::ArmFeasibleSet| {
                let mut v: Vec<(usize, [i64; 7])> =
                    s.configs.iter().map(|c| (c.region, c.q.map(|a| (a * 1e6).round() as i64))).collect();
                v.sort();
                v
            };
            for (a, b) in sorted(&r.feasible).iter().zip(&sorted(&l.feasible)) {
                assert_eq!(a.0, b.0);
                assert!(a.1.iter().zip(&b.1).all(|(x, y)| (x - y).abs() <= 1), "{h} m {id}: {a:?} vs {b:?}");
            }
            let [x, y, z] = r.pose.position;
            let [wx, wy, wz] = r.query.pose.position;
            assert!(
                (x - wx * h / 1.75).abs() < 1e-12
                    && (y - wy * h / 1.75).abs() < 1e-12
                    && (z - wz * h / 1.75).abs() < 1e-12
            );
            assert_eq!(r.pose.rpy_deg.map(|v| (v * 1e9).round()), r.query.pose.rpy_deg.map(|v| (v * 1e9).round()));
            // The left pose: y mirrored, the same height and distance.
            assert!((l.pose.position[0] - x).abs() < 1e-12 && (l.pose.position[1] + y).abs() < 1e-12);
            assert!((l.pose.position[2] - z).abs() < 1e-12);
        }
    }
}

/// The worked example of docs/kinematics.md: `bars-chest-turned-left` for a 1.55 m
/// left-handed participant.
#[test]
fn the_worked_example_of_the_kinematics_doc() {
    use handover::kinematics::Hand;
    use handover::protocol::{Body, for_body};
    let (_, s) = for_body(DEFAULT_PROTOCOL, "default", Body { height_m: Some(1.55), hand: Hand::Left }).unwrap();
    let q = s.query("bars-chest-turned-left").unwrap();
    assert_eq!(q.query.pose.position, [0.42, -0.09, -0.05]);
    assert_eq!(q.query.pose.rpy_deg, [0.0, 0.0, 20.0]);
    let [x, y, z] = q.pose.position;
    assert!((x - 0.372).abs() < 1e-9 && (y - 0.0797).abs() < 1e-4 && (z + 0.0443).abs() < 1e-4, "{:?}", q.pose);
    let [r, p, yaw] = q.pose.rpy_deg;
    assert!(r.abs() < 1e-9 && p.abs() < 1e-9 && (yaw - 160.0).abs() < 1e-9, "{:?}", q.pose);
}
