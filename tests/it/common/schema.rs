//! JSON Schema validation by an independent implementation: Python's
//! `jsonschema` in the test venv (tests/python/schema_check.py), one process
//! per [`Validator`], asked one question a line. The schemas are generated
//! from the protocol's Rust types; a checker that shares no code with that
//! generation is what makes "the schema accepts it" worth asserting.

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

use serde_json::{Value, json};

use super::process::venv_python;

/// A running checker; dropped, it ends.
pub(crate) struct Validator {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
}

impl Validator {
    /// A checker for `test`; `None` (the test is skipped, with a message)
    /// without the venv's `jsonschema`, which CI=true does not allow.
    pub(crate) fn start(test: &str) -> Option<Validator> {
        let python = venv_python(test, &["jsonschema"], "Python's jsonschema")?;
        let mut child = Command::new(python)
            .arg(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/tests/python/schema_check.py"
            ))
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .expect("the venv's Python starts");
        let stdin = child.stdin.take().unwrap();
        let stdout = BufReader::new(child.stdout.take().unwrap());
        Some(Validator {
            child,
            stdin,
            stdout,
        })
    }

    fn ask(&mut self, question: &Value) -> Vec<String> {
        writeln!(self.stdin, "{question}").expect("the checker reads");
        let mut line = String::new();
        self.stdout
            .read_line(&mut line)
            .expect("the checker answers");
        serde_json::from_str(&line).unwrap_or_else(|e| panic!("the checker's answer {line:?}: {e}"))
    }

    /// The errors of `instance` against `schema` (Draft 2020-12), one
    /// line each: "<message> at <instance path>".
    pub(crate) fn errors(&mut self, schema: &Value, instance: &Value) -> Vec<String> {
        self.ask(&json!({"schema": schema, "instance": instance}))
    }

    /// The errors of `schema` against the Draft 2020-12 meta-schema.
    pub(crate) fn meta_errors(&mut self, schema: &Value) -> Vec<String> {
        self.ask(&json!({"meta": schema}))
    }
}

impl Drop for Validator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
