//! What a command says of its outputs and names beside them: the output
//! plan's notes and a batch's problems file.

use std::path::{Path, PathBuf};

use formats::OutputPlan;

/// Print the notes of an output plan (a stale lock taken over).
pub fn print_notes(plan: &OutputPlan) {
    for note in plan.notes() {
        eprintln!("trinocular: note: {note}");
    }
}

/// `<stem>.problems.csv` beside the output `out` of a batch.
pub fn problems_path(out: &Path) -> PathBuf {
    formats::beside(out, "out", ".problems.csv")
}
