//! `handover feasible` as a user runs it.

use crate::support::handover;

fn dist(a: &serde_json::Value, b: &serde_json::Value) -> f64 {
    (0..3).map(|i| (a[i].as_f64().unwrap() - b[i].as_f64().unwrap()).powi(2)).sum::<f64>().sqrt()
}

#[test]
fn json_lists_every_configuration_with_its_arm_points() {
    let (code, out, err) = handover(&["feasible", "--query", "bars-low-level", "--format", "json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let (l1, l2) = (v["upper_arm"].as_f64().unwrap(), v["forearm"].as_f64().unwrap());
    assert_eq!(v["joints"].as_array().unwrap().len(), 7);
    assert_eq!(v["joints"][3], "elbow_flexion");
    assert_eq!(v["limits"].as_array().unwrap().len(), 7);
    let queries = v["queries"].as_array().unwrap();
    assert_eq!(queries.len(), 1);
    let q = &queries[0];
    assert_eq!(q["id"], "bars-low-level");
    assert_eq!(q["object"], "handlebars");
    assert_eq!(q["regions"], serde_json::json!(["left-grip", "right-grip"]));
    let configs = q["configs"].as_array().unwrap();
    assert!(configs.len() > 100);
    for c in configs {
        let p = &c["points"];
        assert!((dist(&p["shoulder"], &p["elbow"]) - l1).abs() < 1e-9);
        assert!((dist(&p["elbow"], &p["wrist"]) - l2).abs() < 1e-9);
        assert!(c["region"] == "left-grip" || c["region"] == "right-grip");
        assert_eq!(c["q"].as_array().unwrap().len(), 7);
    }
}

#[test]
fn csv_has_one_row_per_configuration() {
    let (code, out, _) = handover(&["feasible", "--format", "csv"]);
    assert_eq!(code, 0);
    let mut rows = csv::Reader::from_reader(out.as_bytes());
    let header = rows.headers().unwrap().clone();
    assert_eq!(&header[0], "query");
    assert_eq!((&header[2], &header[4]), ("config_index", "region_label"));
    assert_eq!(&header[5], "q_shoulder_flexion_rad");
    assert_eq!(&header[12], "shoulder_x_m");
    assert_eq!(header.len(), 5 + 7 + 12);
    let records: Vec<csv::StringRecord> = rows.records().map(|r| r.unwrap()).collect();
    let queries: std::collections::BTreeSet<String> = records.iter().map(|r| r[0].to_string()).collect();
    assert_eq!(queries.len(), 24);
    // config_index counts each query's feasible set from 0, as the logs index it.
    let study = handover::protocol::Study::default_study();
    for q in study.all_queries() {
        let idx: Vec<usize> = records.iter().filter(|r| r[0] == q.query.id).map(|r| r[2].parse().unwrap()).collect();
        assert_eq!(idx, (0..q.feasible.configs.len()).collect::<Vec<_>>(), "{}", q.query.id);
    }
    assert!(records.iter().any(|r| &r[4] == "Left grip (blue)"));
}

/// The default table: one line per query with its configurations, in all and per grip, as
/// many as the CSV has.
#[test]
fn the_table_counts_each_querys_configurations_per_grip() {
    let (code, table, err) = handover(&["feasible"]);
    assert_eq!(code, 0, "{err}");
    let (_, csv_text, _) = handover(&["feasible", "--format", "csv"]);
    let mut rows = csv::Reader::from_reader(csv_text.as_bytes());
    let records: Vec<csv::StringRecord> = rows.records().map(|r| r.unwrap()).collect();
    let study = handover::protocol::Study::default_study();
    for q in study.all_queries() {
        let line = table
            .lines()
            .find(|l| l.split_whitespace().next() == Some(q.query.id.as_str()))
            .unwrap_or_else(|| panic!("no line for {}:\n{table}", q.query.id));
        let mine: Vec<&csv::StringRecord> = records.iter().filter(|r| r[0] == q.query.id).collect();
        let words: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(words[2], mine.len().to_string(), "{line}");
        let grips: std::collections::BTreeSet<&str> = mine.iter().map(|r| &r[3]).collect();
        for grip in grips {
            let n = mine.iter().filter(|r| &r[3] == grip).count();
            assert!(line.contains(&format!("{grip} {n}")), "{line}: {grip} has {n}");
        }
    }
}

#[test]
fn plots_one_svg_per_query() {
    let dir = std::env::temp_dir().join(format!("handover-plot-{}", std::process::id()));
    let (code, _, err) = handover(&["feasible", "--query", "lock-low-upright", "--plot", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let svg = std::fs::read_to_string(dir.join("lock-low-upright.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.contains("Left shackle grip"));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn bad_protocol_or_query_exits_2() {
    let (code, _, err) = handover(&["feasible", "--query", "nope"]);
    assert_eq!(code, 2);
    assert!(err.contains("--query: unknown query 'nope'"), "{err}");
    let (code, _, err) = handover(&["feasible", "--protocol", "/nonexistent/p.json"]);
    assert_eq!(code, 2);
    assert!(err.contains("/nonexistent/p.json"), "{err}");
    let (code, _, _) = handover(&["feasible", "--format", "xml"]);
    assert_eq!(code, 2);
}
