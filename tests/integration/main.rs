//! The integration tests, one module per capability, linked into one test binary (one link
//! instead of one per file).

mod support;

mod analyze_cli;
mod architecture;
mod console;
mod console_combinations;
mod console_tmux;
mod durability;
mod engine_properties;
mod estimates;
mod feasible_cli;
mod figures;
mod golden;
mod hostile_inputs;
mod indexed_readers;
mod learning_ahead;
mod live_view;
mod log_reader;
mod measured_session;
mod outputs;
mod plan_cli;
mod precision;
mod protocol_validation;
mod robot_hook;
mod robot_ros2;
mod score_cli;
mod session_log;
mod shards;
mod simulate_cli;
mod study_cli;
mod withdrawal;
