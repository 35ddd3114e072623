//! The command line's vocabulary: what each long flag means and its default, in one table, and
//! the spellings renamed in 0.2.0, which still work (with a warning) until 0.4.0.
//!
//! A flag means one thing in every command that takes it. A command that sweeps a setting
//! takes a comma-separated list under the same flag (`research front --learn q-star,weights`),
//! one that runs a single setting takes one value. Where a command's default differs from the
//! others', the table says which and why. A test walks the clap definition against this
//! table, so a new flag cannot be added without a meaning, nor a default that disagrees with
//! the same flag elsewhere; `docs/reference.md` prints the table.

use std::ffi::OsString;

/// A long flag: what it means, the value it takes, its default, and the commands whose
/// default differs (with why).
pub struct Concept {
    pub flag: &'static str,
    pub meaning: &'static str,
    /// The value's name in help, without the `,…` of a list (empty for a switch).
    pub value: &'static str,
    pub default: Option<&'static str>,
    pub except: &'static [Exception],
}

/// A command whose default for a flag differs from the table's, and why.
pub struct Exception {
    pub command: &'static str,
    pub default: Option<&'static str>,
    pub why: &'static str,
}

const fn c(flag: &'static str, value: &'static str, default: Option<&'static str>, meaning: &'static str) -> Concept {
    Concept { flag, meaning, value, default, except: &[] }
}

/// Every long flag of every command.
pub const CONCEPTS: &[Concept] = &[
    // The study and its people.
    c("protocol", "FILE", None, "the protocol file (default: the embedded protocols/bike-handover.json)"),
    c(
        "study-dir",
        "DIR",
        None,
        "the study's folder: participants/ and logs/ (default: $HANDOVER_STUDY_DIR where a command starts from the study, the log's own study where it starts from a log, else the current folder)",
    ),
    c("participants-dir", "DIR", None, "where participant records live (default: STUDY_DIR/participants)"),
    c("logs", "DIR", None, "where session logs live (default: STUDY_DIR/logs)"),
    Concept {
        except: &[Exception {
            command: "run",
            default: Some("new"),
            why: "a session is for a new participant unless one is named",
        }],
        ..c("participant", "ID", None, "a participant's pseudonymous id")
    },
    c("participants", "PARTICIPANTS", Some("1"), "how many simulated participants a dry run has"),
    c("body-height", "M", None, "a participant's body height, metres"),
    c("handedness", "HANDEDNESS", None, "a participant's dominant hand: left or right"),
    c("left-handed-share", "FRACTION", Some("0.1"), "the share of left-handed participants drawn"),
    c("population", "POPULATION", Some("protocol"), "whom simulated participants' λ are drawn from"),
    c(
        "population-file",
        "FILE",
        None,
        "a protocol's `population` section (q* in degrees), e.g. the one `analyze --fit-population` writes",
    ),
    c(
        "prior-file",
        "FILE",
        None,
        "a protocol's `learning.prior` section (q* in degrees), e.g. the next study's that `analyze --fit-population` writes",
    ),
    c(
        "precision",
        "PRECISION",
        Some("float64"),
        "the arithmetic of the selectors' information gain and expected cost: float64, or float32 (its tolerance in docs/engine.md)",
    ),
    c("truth", "FILE", None, "one ground truth λ for every simulated participant"),
    c("pilot", "", None, "a pilot with a real person: a `pilot-` id, no record, the log flagged pilot"),
    c("practice", "", None, "a rehearsal where a simulated participant chooses and the operator presses every key"),
    c(
        "simulated-participant",
        "",
        None,
        "a simulated participant answers in the console (a rehearsal; the log is flagged pilot)",
    ),
    c("no-console", "", None, "continue a dry run with its simulated participant, without the console"),
    c(
        "pace",
        "MS",
        None,
        "milliseconds between a simulated participant's actions (default: 800 where the console shows them, 0 where nothing does)",
    ),
    c("fork", "", None, "continue this log even though a newer continuation of it exists"),
    c("delete-data", "", None, "also delete the participant's logs and record"),
    c("yes", "", None, "do not ask before deleting"),
    c("bodies", "", None, "report the body heights and hands a protocol serves"),
    // Randomness and repetition.
    Concept {
        except: &[Exception {
            command: "run",
            default: None,
            why: "a real session's seed is drawn at random (and recorded in its log): two participants never share one",
        }],
        ..c("seed", "SEED", Some("0"), "the seed of every random draw; the same seed gives the same result")
    },
    Concept {
        except: &[Exception {
            command: "dry-run",
            default: Some("1"),
            why: "a dry run's first use is pilot logs; --seeds turns it into a study over seeds",
        }],
        ..c(
            "seeds",
            "N",
            Some("5"),
            "run seeds SEED, SEED+1, …, and report each measure over them with a 95 % interval",
        )
    },
    c("threads", "THREADS", None, "worker threads (default: all cores); results do not depend on it"),
    // The simulations.
    Concept {
        except: &[Exception {
            command: "research front",
            default: Some("q-star,weights"),
            why: "the front is drawn per learned part: one panel each",
        }],
        ..c(
            "learn",
            "LEARN",
            Some("q-star"),
            "what is learned: q-star, weights or both (a list where a command sweeps it)",
        )
    },
    c("scenarios", "SCENARIOS", Some("planar2,arm7"), "the simulated scenarios swept"),
    c("trials", "TRIALS", Some("20"), "trials per seed, each with its own truth, menu and test set"),
    c("menu", "MENU", Some("8"), "queries on each trial's menu"),
    c("iterations", "ITERATIONS", None, "queries per selector and trial (default: the scenario's)"),
    c("test-size", "TEST_SIZE", Some("300"), "test queries answered per trial"),
    c("particles", "PARTICLES", Some("1000"), "particles in the belief"),
    c("alpha", "ALPHA", None, "the rationality α (default: the scenario's)"),
    Concept {
        except: &[Exception {
            command: "research observations",
            default: Some("active,passive"),
            why: "it compares observation models under the two selectors a study compares",
        }],
        ..c("algorithms", "ALGORITHMS", Some("active,active-paper,passive,random,hybrid"), "the query selectors run")
    },
    c("beta", "BETA", Some("0.1"), "β of `hybrid`: information gain − β · expected cost"),
    c("epsilon", "EPSILON", Some("0.25"), "ε of `budgeted`: expected cost at most (1 + ε) × the passive query's"),
    c("betas", "BETAS", Some("0.03,0.1,0.3,1,3"), "the β values of `hybrid` swept"),
    c("epsilons", "EPSILONS", Some("0,0.1,0.25,0.5,1"), "the ε values of `budgeted` swept"),
    c(
        "estimate",
        "ESTIMATE",
        Some("mean"),
        "the point estimate measured: posterior mean, MAP particle or gridded mode",
    ),
    c("observation", "OBSERVATION", Some("configuration"), "what the learner observes of a choice"),
    Concept {
        except: &[Exception {
            command: "research observations",
            default: Some("2,5,10,20"),
            why: "it sweeps the noise levels",
        }],
        ..c(
            "sigma-deg",
            "DEG",
            None,
            "the measurement noise σ per joint, degrees (one for every joint, one per joint, or a list where a command sweeps it)",
        )
    },
    // Planning and batches.
    c("sizes", "SIZES", Some("5,10,20,40"), "the study sizes (participants) a plan is made for"),
    c("studies", "STUDIES", Some("200"), "simulated studies per size"),
    c("keep-logs", "LOGS", None, "also write the first simulated study's sessions as pilot logs"),
    c("shard", "K/N", None, "run only shard K of N, as one task of a batch scheduler's job array"),
    c("merge", "DIR", None, "join the shard folders of the same command into what the whole run writes"),
    c("versus", "FILE", None, "also run the same participants under a second protocol, paired"),
    // Outputs.
    c("out", "DIR", None, "the folder the CSVs and figures are written into"),
    Concept {
        except: &[Exception { command: "man", default: Some("roff"), why: "a manual page has no table" }],
        ..c("format", "FORMAT", Some("table"), "what is written on stdout: table, json or csv")
    },
    c("figure-formats", "FORMATS", Some("svg"), "the formats every figure is written in: svg, pdf, png"),
    c("figure-width", "WIDTH", Some("two-column"), "the figures' width: one-column or two-column"),
    c("plot", "DIR", None, "also write one figure per query into DIR"),
    c("query", "ID", None, "only this query"),
    // Analysis.
    c("verify", "", None, "recompute every derived value of each log and report any difference"),
    c("alpha-particles", "N", Some("20000"), "prior draws of λ over which each session's evidence for α is integrated"),
    c("measurements", "FILE", None, "time-stamped joint angles from a measuring system (CSV or C3D)"),
    c("fit-population", "", None, "also fit the population the participants come from"),
    c("joint-names", "NAME", None, "the measuring system's names of the model's 7 joints"),
    c("c3d-start", "TIME", None, "the wall-clock time of a C3D file's first frame"),
    c("window-s", "S", None, "how long before a grasp its sample may lie, seconds"),
    // The robot and the live view.
    c("robot", "ROBOT", None, "drive the robot over ROS 2"),
    c("robot-command", "PROGRAM", None, "drive the robot through a program, one JSON line per query"),
    c("robot-config", "FILE", None, "the lab's robot settings (JSON)"),
    c("measure", "MEASURE", None, "measure the participant's arm live"),
    c("live", "ADDR", None, "serve the session's topics to Foxglove on ADDR"),
    c("wait-s", "S", Some("3"), "seconds to wait for DDS discovery"),
];

/// A spelling renamed in 0.2.0: a flag of `command`, or (with `command` empty) a command.
pub struct Renamed {
    pub command: &'static str,
    pub old: &'static str,
    pub new: &'static str,
}

/// Every renamed spelling.
pub const RENAMED: &[Renamed] = &[
    Renamed { command: "", old: "simulate", new: "research simulate" },
    Renamed { command: "", old: "front", new: "research front" },
    Renamed { command: "", old: "observations", new: "research observations" },
    Renamed { command: "", old: "score", new: "research score" },
    Renamed { command: "run", old: "--simulate", new: "--simulated-participant" },
    Renamed { command: "resume", old: "--simulate", new: "--simulated-participant" },
    Renamed { command: "resume", old: "--dry-run", new: "--no-console" },
    Renamed { command: "plan", old: "--participants", new: "--sizes" },
    Renamed { command: "research observations", old: "--sigmas-deg", new: "--sigma-deg" },
];

/// The warnings for the renamed spellings in a command line (its first word the program).
pub fn renamed_in(args: &[OsString]) -> Vec<String> {
    let words: Vec<String> = args.iter().skip(1).map(|a| a.to_string_lossy().into_owned()).collect();
    let mut path: Vec<&str> = words.iter().map(String::as_str).take_while(|w| !w.starts_with('-')).take(2).collect();
    let mut warnings = Vec::new();
    // A moved command: warned about, and its flags looked up under its new name.
    if let Some(moved) = RENAMED.iter().find(|r| r.command.is_empty() && path.first() == Some(&r.old)) {
        warnings
            .push(format!("`handover {}` is now `handover {}`; the old name works until 0.4.0", moved.old, moved.new));
        path = moved.new.split(' ').collect();
    }
    let flags = words.iter().take_while(|w| *w != "--").filter(|w| w.starts_with("--"));
    for word in flags {
        for r in RENAMED.iter().filter(|r| !r.command.is_empty()) {
            let named = word == r.old || word.strip_prefix(r.old).is_some_and(|rest| rest.starts_with('='));
            let command: Vec<&str> = r.command.split(' ').collect();
            if named && path.starts_with(&command) {
                warnings.push(format!(
                    "`handover {} {}` is now `{}`; the old spelling works until 0.4.0",
                    r.command, r.old, r.new
                ));
            }
        }
    }
    warnings
}

/// Prints a warning for each renamed spelling in the command line.
pub fn warn_renamed(args: &[OsString]) {
    for warning in renamed_in(args) {
        eprintln!("handover: {warning}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::{Arg, ArgAction, Command, CommandFactory, Parser};

    /// A long flag where it is used: the command's path, and the flag.
    struct Use {
        command: String,
        arg: Arg,
    }

    fn uses(cmd: &Command, path: &str, out: &mut Vec<Use>) {
        for a in cmd.get_arguments() {
            if a.get_long().is_some() && !["help", "version"].contains(&a.get_id().as_str()) {
                out.push(Use { command: path.to_string(), arg: a.clone() });
            }
        }
        for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set() && s.get_name() != "help") {
            let p = if path.is_empty() { sub.get_name().to_string() } else { format!("{path} {}", sub.get_name()) };
            uses(sub, &p, out);
        }
    }

    fn all_uses() -> Vec<Use> {
        let mut cmd = crate::cli::Cli::command();
        cmd.build();
        let mut out = Vec::new();
        uses(&cmd, "", &mut out);
        out
    }

    fn is_switch(a: &Arg) -> bool {
        matches!(a.get_action(), ArgAction::SetTrue | ArgAction::SetFalse | ArgAction::Count)
    }

    /// Every flag of every command is in the table, with the table's value name and default
    /// (or the command's recorded exception); every entry of the table is used.
    #[test]
    fn every_flag_means_one_thing_with_one_default() {
        let mut problems = Vec::new();
        let uses = all_uses();
        for u in &uses {
            let long = u.arg.get_long().expect("long flags only");
            let Some(concept) = CONCEPTS.iter().find(|c| c.flag == long) else {
                problems.push(format!("{} --{long}: not in the vocabulary (src/cli/vocabulary.rs)", u.command));
                continue;
            };
            if is_switch(&u.arg) {
                if !concept.value.is_empty() {
                    problems.push(format!(
                        "{} --{long} is a switch; the vocabulary says it takes {}",
                        u.command, concept.value
                    ));
                }
                continue;
            }
            let value = u.arg.get_value_names().and_then(|v| v.first()).map_or(String::new(), |v| v.to_string());
            if value.trim_end_matches(",…").split('|').next() != Some(concept.value) {
                problems.push(format!("{} --{long} takes {value}; the vocabulary says {}", u.command, concept.value));
            }
            let default: Vec<String> =
                u.arg.get_default_values().iter().map(|v| v.to_string_lossy().into_owned()).collect();
            let default = (!default.is_empty()).then(|| default.join(","));
            let expected =
                concept.except.iter().find(|e| e.command == u.command).map_or(concept.default, |e| e.default);
            if default.as_deref() != expected {
                problems.push(format!(
                    "{} --{long} defaults to {default:?}; the vocabulary says {expected:?} (add an exception with its reason, or agree)",
                    u.command
                ));
            }
            if let Some(env) = u.arg.get_env()
                && (env != "HANDOVER_STUDY_DIR" || long != "study-dir")
            {
                problems.push(format!(
                    "{} --{long} reads {env:?}; only --study-dir reads an environment variable",
                    u.command
                ));
            }
        }
        for concept in CONCEPTS {
            let used: Vec<&Use> = uses.iter().filter(|u| u.arg.get_long() == Some(concept.flag)).collect();
            if used.is_empty() {
                problems.push(format!("--{}: in the vocabulary but no command takes it", concept.flag));
            }
            for e in concept.except {
                if !used.iter().any(|u| u.command == e.command) {
                    problems
                        .push(format!("--{}: an exception for `{}`, which does not take it", concept.flag, e.command));
                }
            }
        }
        assert!(problems.is_empty(), "{}", problems.join("\n"));
    }

    /// Each renamed flag's new spelling exists in its command and still accepts the old one,
    /// hidden from help; each moved command is hidden under its old name.
    #[test]
    fn renamed_spellings_still_parse_hidden() {
        let uses = all_uses();
        for r in RENAMED {
            if r.command.is_empty() {
                let top = crate::cli::Cli::command();
                let old = top.find_subcommand(r.old).unwrap_or_else(|| panic!("{} is gone", r.old));
                assert!(old.is_hide_set(), "{} is not hidden", r.old);
                let new: Vec<&str> = r.new.split(' ').collect();
                assert!(top.find_subcommand(new[0]).and_then(|c| c.find_subcommand(new[1])).is_some(), "{}", r.new);
                continue;
            }
            let new = r.new.trim_start_matches("--");
            let u = uses
                .iter()
                .find(|u| u.command == r.command && u.arg.get_long() == Some(new))
                .unwrap_or_else(|| panic!("{} has no {}", r.command, r.new));
            let aliases = u.arg.get_all_aliases().unwrap_or_default();
            assert!(aliases.contains(&r.old.trim_start_matches("--")), "{} {}: no alias {}", r.command, r.new, r.old);
            assert!(
                u.arg.get_visible_aliases().is_none_or(|v| v.is_empty()),
                "{} {}: the old spelling shows in help",
                r.command,
                r.new
            );
        }
    }

    fn line(words: &str) -> Vec<OsString> {
        std::iter::once("handover").chain(words.split(' ')).map(OsString::from).collect()
    }

    #[test]
    fn renamed_spellings_warn_once_and_only_where_they_were_used() {
        assert_eq!(renamed_in(&line("plan --participants 5,10")).len(), 1);
        assert_eq!(renamed_in(&line("plan --participants=5,10")).len(), 1);
        assert!(renamed_in(&line("dry-run --participants 5")).is_empty(), "dry-run's --participants is a count");
        assert!(renamed_in(&line("run --simulated-participant")).is_empty());
        assert!(renamed_in(&line("run --robot-command x -- --simulate")).is_empty(), "after --, a value");
        let moved = renamed_in(&line("observations --sigmas-deg 2,5"));
        assert_eq!(moved.len(), 2, "{moved:?}");
        assert!(moved[0].contains("research observations") && moved[1].contains("--sigma-deg"), "{moved:?}");
        assert_eq!(renamed_in(&line("resume x.mcap --dry-run --simulate")).len(), 2);
        assert!(renamed_in(&line("research simulate arm7")).is_empty());
    }

    /// The old spellings parse to what the new ones do.
    #[test]
    fn old_and_new_spellings_parse_the_same() {
        for (old, new) in [
            ("plan --participants 5,10", "plan --sizes 5,10"),
            ("simulate arm7 --seeds 2", "research simulate arm7 --seeds 2"),
            ("observations --sigmas-deg 2,5", "research observations --sigma-deg 2,5"),
            ("run --simulate", "run --simulated-participant"),
            ("resume x.mcap --dry-run", "resume x.mcap --no-console"),
        ] {
            let parse = |words: &str| {
                let cli = crate::cli::Cli::try_parse_from(line(words)).unwrap_or_else(|e| panic!("{words}: {e}"));
                format!("{cli:?}").replace("Research(", "").replace("Simulate(", "").replace("Observations(", "")
            };
            let (o, n) = (parse(old), parse(new));
            let strip = |s: &str| s.replace(['(', ')'], "");
            assert_eq!(strip(&o), strip(&n), "{old} / {new}");
        }
    }
}
