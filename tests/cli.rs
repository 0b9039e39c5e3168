//! Every subcommand's flags with hostile values: NaN, ∞, 0, negative, huge, empty, wrong
//! counts, unknown names, and flags that do not apply to the method or the model. Each row is
//! `arguments ⇒ a piece of the message`; each must end at once with exit code 2 and a one-line
//! message naming the flag or the name, never a panic, a hang or silent acceptance.

mod common;

use common::lasalle_within;

/// `{out}` in a row is replaced by a path in the test's scratch directory.
const ROWS: &[(&[&str], &str)] = &[
    // the command line itself
    (&["frobnicate"], "unrecognized subcommand"),
    (&["run"], "required"),
    // run: numbers
    (&["run", "kepler", "--dt", "nan"], "--dt"),
    (&["run", "kepler", "--dt", "inf"], "--dt"),
    (&["run", "kepler", "--dt", "0"], "--dt"),
    (&["run", "kepler", "--dt", "-1"], "--dt"),
    (&["run", "kepler", "--dt", ""], "--dt"),
    (&["run", "kepler", "--t-end", "1e400"], "--t-end"),
    (&["run", "kepler", "--dt", "2", "--t-end", "1"], "exceeds the end time"),
    (&["run", "kepler", "--dt", "1e-300", "--t-end", "1"], "--max-steps"),
    (&["run", "kepler", "--every", "0"], "--every"),
    (&["run", "kepler", "--every", "-3"], "--every"),
    (&["run", "kepler", "--every", "1.5"], "--every"),
    (&["run", "kepler", "--max-steps", "0"], "--max-steps"),
    (&["run", "kepler", "--max-steps", "99999999999999999999999"], "--max-steps"),
    (&["run", "kepler", "--max-drift", "nan"], "--max-drift"),
    (&["run", "kepler", "-m", "dopri5", "--rtol", "0"], "--rtol"),
    (&["run", "kepler", "-m", "dopri5", "--atol", "-1e-9"], "--atol"),
    (&["run", "kepler", "-m", "projection-euler", "--projection-tol", "inf"], "--projection-tol"),
    // run: names and counts
    (&["run", "nosuch"], "no model `nosuch`"),
    (&["run", "no/such/file.lsl"], "cannot read model file"),
    (&["run", "kepler", "-m", "nope"], "unknown method `nope`"),
    (&["run", "kepler", "-m", ""], "unknown method"),
    (&["run", "kepler", "--preset", "nope"], "unknown preset `nope`"),
    (&["run", "kepler", "--backend", "gpu"], "--backend"),
    (&["run", "kepler", "--format", "yaml"], "possible values"),
    (&["run", "kepler", "--param", "zz=1"], "unknown parameter `zz`"),
    (&["run", "kepler", "--param", "mu=1,2"], "takes 1 value"),
    (&["run", "kepler", "--param", "mu"], "expected `name=value"),
    (&["run", "kepler", "--param", "mu=nan"], "not a finite number"),
    (&["run", "kepler", "--param", "mu="], "not a finite number"),
    (&["run", "kepler", "--init", "nowhere"], "unknown point `nowhere`"),
    (&["run", "kepler", "--init", "1,2"], "dimension 6"),
    (&["run", "kepler", "--init", "1,0,0,0,inf,0"], "not a finite number"),
    (&["run", "kepler", "--init", "0,0,0,0,1,0"], "guard `collision`"),
    (&["run", "kepler", "-m", "euler", "--init", "0,0,0,0,0,0"], "invalid initial state"),
    (&["run", "duffing", "--init", "1e200,1e200"], "not finite at the initial state"),
    (&["run", "kepler", "--gains", "-1,2"], "≥ 0"),
    (&["run", "kepler", "--gains", "adaptive:0"], "at least 1 step"),
    (&["run", "kepler", "--gains", "fixed:5"], "not in (0, 2)"),
    (&["run", "kepler", "--gains", "sometimes"], "invalid gain specification"),
    (&["run", "rigid-body", "--t-end", "0"], "--t-end"),
    (&["run", "kepler", "--t-end", "1e300"], "would take 2.000e302 steps, more than the limit of 1000000000: raise it with --max-steps"),
    (&["run", "pendulum"], "no model `pendulum`: give a path to a model file (`my_model.lsl`) or one of the built-in models: arenstorf, coupled_oscillators, cr3bp,"),
    (&["run", "kepler", "--init", "1,0,0,0,1"], "--init has 5 numbers but the state of `Kepler` has dimension 6"),
    (&["run", "kepler", "--gains", "1,2,3"], "expected 2 gains, got 3"),
    (&["run", "kepler", "--preset", "fast"], "unknown preset `fast`; the model's presets: paper"),
    (&["run", "kepler", "--backend", "llvm"], "invalid value 'llvm' for '--backend <BACKEND>'"),
    // run: flags that do not apply to the method or the model
    (&["run", "rigid-body", "-m", "stormer-verlet-a"], "method `stormer-verlet-a` needs a partitioned model"),
    (&["run", "kepler", "-m", "euler", "--gains", "fixed"], "--gains applies to feedback methods"),
    (&["run", "kepler", "-m", "taylor", "--tol", "1e-15"], "unexpected argument '--tol'"),
    (&["run", "kepler", "-m", "euler", "--rtol", "1e-8"], "--rtol applies to adaptive methods"),
    (&["run", "kepler", "-m", "rk4", "--atol", "1e-8"], "--atol applies to adaptive methods"),
    (&["run", "kepler", "-m", "dopri5", "--gains", "auto"], "--gains applies to feedback"),
    (&["run", "kepler", "-m", "rk4", "--projection-tol", "1e-6"], "--projection-tol applies"),
    (&["run", "kepler", "-m", "taylor", "--rtol", "1e-12", "--atol", "1e-10"], "one tolerance"),
    (&["run", "kepler", "--gains", "step"], "--gains step follows the step"),
    (&["run", "kepler", "-m", "splitting"], "`Kepler` declares none"),
    (&["run", "duffing", "-m", "stormer-verlet-a", "--dt", "0.1"], "partitioned"),
    (&["run", "duffing", "-m", "symplectic6", "--dt", "0.1"], "method `symplectic6` needs a partitioned model"),
    (&["run", "kepler", "-m", "symplectic5"], "unknown method `symplectic5`"),
    // sweep and sweep-merge
    (&["sweep", "kepler", "--t-end", "0", "--out", "{out}"], "--t-end"),
    (&["sweep", "kepler", "--out", "{out}"], "--t-end"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "--tol", "1e-8"], "unexpected argument '--tol'"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "-m", "rk4"], "give --dt"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "-m", "rk4", "--dt", "0.1", "--rtol", "1e-8"], "--rtol applies"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "--grid", "mu=1:2:0"], "not a count"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "--grid", "mu=1:nan:3"], "not a finite number"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "--grid", "mu=1:2:1"], "invalid --grid `mu=1:2:1`: one value from 1 to 2: give start = stop, or the value alone"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "--grid", "mu=1:2"], "invalid --grid `mu=1:2`: write `start:stop:count`"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "--grid", "mu"], "expected `name="),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "--grid", "zz=1,2"], "neither a parameter"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "--shard", "3/2"], "--shard"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "--shard", "0/0"], "--shard"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "--lanes", "0"], "--lanes"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "--threads", "0"], "--threads"),
    (&["sweep", "kepler", "--t-end", "1", "--out", "{out}", "--list", "no/such.csv"], "cannot read --list"),
    (&["sweep-merge", "no/such.csv", "--out", "{out}"], "cannot read"),
    (&["sweep-merge", "--out", "{out}"], "required"),
    // stability: each analysis refuses the others' flags
    (&["stability", "cr3bp", "--casimir", "1"], "--casimir does not apply"),
    (&["stability", "cr3bp", "--at", "1,2"], "--at does not apply"),
    (&["stability", "cr3bp", "--radius", "1"], "--radius does not apply"),
    (&["stability", "so3_type_i", "--time-bound", "1e-3,1e-2"], "--time-bound does not apply"),
    (&["stability", "duffing", "--time-bound", "1e-3,1e-2"], "--time-bound does not apply"),
    (&["stability", "duffing", "--levels", "10"], "--levels does not apply"),
    (&["stability", "cr3bp", "--time-bound", "1"], "expected D0,D1"),
    (&["stability", "cr3bp", "--time-bound", "nan,1"], "not a finite number"),
    (&["stability", "cr3bp", "--order", "0"], "--order"),
    (&["stability", "cr3bp", "--time-bound", "1e-3,1e-1", "--order", "200"], "between 4 and 120"),
    (&["stability", "cr3bp", "--time-bound", "1e-3,1e-1", "--order", "3"], "between 4 and 120"),
    (&["stability", "cr3bp", "--horizon", "5"], "--validate"),
    (&["stability", "so3_type_i", "--for-time", "1e3"], "--for-time does not apply"),
    (&["stability", "duffing", "--for-time", "1e3"], "--for-time does not apply"),
    (&["stability", "cr3bp", "--for-time", "0"], "--for-time"),
    (&["stability", "cr3bp", "--for-time", "inf"], "--for-time"),
    (&["stability", "cr3bp", "--outer-ratio", "3"], "--for-time"),
    (&["stability", "cr3bp", "--for-time", "1e3", "--outer-ratio", "1"], "--outer-ratio 1: need a finite ratio d1/d0 > 1"),
    (&["stability", "cr3bp", "--validate"], "--validate needs --time-bound"),
    (&["stability", "so3_type_i", "--levels", "0"], "--levels"),
    (&["stability", "so3_type_i", "--casimir", "-1"], "--casimir"),
    (&["stability", "so3_type_i", "--range", "2:1"], "--range"),
    (&["stability", "so3_type_i", "--at", "1,2"], "3 numbers"),
    (&["stability", "so3_type_i", "--format", "csv"], "--format csv"),
    (&["stability", "duffing", "--format", "csv"], "--format csv"),
    (&["stability", "so3_type_i", "--param", "c1=nan"], "not a finite number"),
    // normal-form
    (&["normal-form", "cr3bp", "--order", "1"], "--order"),
    (&["normal-form", "cr3bp", "--order", "-1"], "--order"),
    (&["normal-form", "cr3bp", "--order", "100000"], "--order"),
    (&["normal-form", "cr3bp", "--resonance-tol", "nan"], "--resonance-tol"),
    (&["normal-form", "cr3bp", "--resonance-tol", "inf"], "--resonance-tol"),
    (&["normal-form", "cr3bp", "--resonance-tol", "-1e-3"], "--resonance-tol"),
    (&["normal-form", "cr3bp", "--param", "mu=nan"], "`--param mu=nan`: the value must be a finite number"),
    (&["normal-form", "cr3bp", "--order", "121"], "`--order 121`: the truncation degree must be between 2 and 120"),
    (&["normal-form", "cr3bp", "--max-rel-error", "0"], "--max-rel-error"),
    (&["normal-form", "cr3bp", "--max-rel-error", "nan"], "--max-rel-error"),
    (&["normal-form", "cr3bp", "--at", "0.5,inf,0,0"], "`--at 0.5,inf,0,0`: `inf` is not a finite number"),
    (&["normal-form", "cr3bp", "--max-rel-error", "2"], "--max-rel-error"),
    (&["normal-form", "cr3bp", "--precision", "quad"], "possible values"),
    (&["normal-form", "cr3bp", "--param", "mu=abc"], "not a number"),
    (&["normal-form", "cr3bp", "--param", "zz=1"], "unknown parameter `zz`"),
    (&["normal-form", "cr3bp", "--at", "L9"], "unknown point `L9`"),
    (&["normal-form", "cr3bp", "--at", "1,nan"], "not a finite number"),
    (&["normal-form", "cr3bp", "--format", "yaml"], "possible values"),
    // gen, experiment, bench-eval
    (&["gen", "nosuch"], "no model `nosuch`"),
    (&["gen", "kepler", "--runtime-path", "x"], "--crate"),
    (&["gen", "kepler", "--out", "{out}", "--crate", "{out}"], "cannot be used with"),
    (&["gen", "kepler", "--variational", "--tangents", "7"], "--tangents 7: the number of tangent vectors is between 1 and the state's dimension, 6"),
    (&["gen", "kepler", "--variational", "--tangents", "0"], "--tangents 0"),
    (&["gen", "kepler", "--tangents", "2"], "--variational"),
    (&["gen", "kepler", "--variational", "--indicators"], "cannot be used with"),
    (&["gen", "kepler", "--indicators", "--families", "loops"], "--families loops: the variational equations and the chaos indicators have no loop form"),
    (&["gen", "kepler", "--families", "rolled"], "possible values"),
    (&["experiment", "double-pendulum"], "unknown experiment `double-pendulum`"),
    (&["experiment", "kepler", "--dt", "0"], "--dt"),
    (&["experiment", "kepler", "--periods", "nan"], "--periods"),
    (&["experiment", "kepler", "--t-end", "-5"], "--t-end"),
    (&["bench-eval", "kepler", "--lanes", "0"], "--lanes"),
    (&["bench-eval", "kepler", "--lanes", ""], "--lanes"),
    (&["bench-eval", "kepler", "--states", "0"], "--states"),
    (&["bench-eval", "kepler", "--seconds", "-1"], "--seconds"),
    (&["bench-eval", "kepler", "--chain", "--lanes", "4"], "--chain"),
];

#[test]
fn hostile_flags_are_refused_in_one_line_with_exit_code_2() {
    let scratch = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cli-flags");
    std::fs::create_dir_all(&scratch).unwrap();
    let out = scratch.join("out.csv");
    let out = out.to_str().unwrap();
    let mut failures = Vec::new();
    for (args, expected) in ROWS {
        let args: Vec<&str> = args
            .iter()
            .map(|a| if *a == "{out}" { out } else { a })
            .collect();
        let shown = args.join(" ");
        let Some(o) = lasalle_within(&args, 60) else {
            failures.push(format!("`{shown}`: still running after 60 s"));
            continue;
        };
        let stderr = String::from_utf8_lossy(&o.stderr);
        let message = stderr.trim_end();
        if o.status.code() != Some(2) {
            failures.push(format!(
                "`{shown}`: exit {:?}, stderr: {message}",
                o.status.code()
            ));
        } else if message.lines().count() != 1 || !message.starts_with("error: ") {
            failures.push(format!("`{shown}`: not one `error:` line: {message:?}"));
        } else if !message.contains(expected) {
            failures.push(format!("`{shown}`: `{message}` does not say `{expected}`"));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} rows:\n{}",
        failures.len(),
        ROWS.len(),
        failures.join("\n")
    );
}

/// A reader that closes the pipe before lasalle prints (`lasalle … | head -1`) ends it quietly,
/// as it ends `cat`: no panic on the write.
#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_the_output_without_a_panic() {
    use std::os::unix::process::ExitStatusExt;
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_lasalle"))
        .args(["gen", "models/kepler.lsl"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the lasalle binary runs");
    // the read end closes before the model is even parsed
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("lasalle ends");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.signal(), Some(libc::SIGPIPE), "{stderr}");
}

/// A model file that does not load is exit code 3 in every subcommand that reads one, with
/// the diagnostic located in the file (a run that fails is 1, a mistyped flag 2).
#[test]
fn a_broken_model_is_exit_code_3_in_every_subcommand() {
    let scratch = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cli-model-error");
    std::fs::create_dir_all(&scratch).unwrap();
    let file = scratch.join("broken.lsl");
    std::fs::write(
        &file,
        "model Broken {\n    state x: vec2;\n    param a = 1;\n    d/dt x = [x[1], -a * y];\n}\n",
    )
    .unwrap();
    let file = file.to_str().unwrap();
    let out = scratch.join("out");
    let out = out.to_str().unwrap();
    let rows: &[&[&str]] = &[
        &["run", file, "--dt", "0.1", "--t-end", "1", "--init", "1,0"],
        &["gen", file],
        &[
            "sweep", file, "--grid", "a=1:2:2", "--dt", "0.1", "--t-end", "1", "--out", out,
        ],
        &["normal-form", file],
        &["stability", file],
    ];
    for args in rows {
        let o = lasalle_within(args, 60).expect("ends within 60 s");
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(3), "`{}`: {stderr}", args.join(" "));
        assert!(
            stderr.contains("broken.lsl:4"),
            "`{}`: {stderr}",
            args.join(" ")
        );
        assert!(stderr.contains("`y`"), "`{}`: {stderr}", args.join(" "));
    }
}
