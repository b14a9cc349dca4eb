//! A test campaign: the records (hits, runs) of one set-up with the names of
//! their channels and of the records themselves.
//!
//! This is the one shape in which data reach the identifier, whether they
//! come from files (the `records` crate selects channels into it), from the
//! simulator (the `sim` crate converts its campaigns into it) or from code.
//! Names are used in messages only; the numbers are in [`Record`]s.

use crate::record::Record;
use serde::{Deserialize, Serialize};

/// Records sampled every `dt_s` seconds, with channel and record names.
///
/// Invariants (asserted by the constructors, which are the only way code
/// should build one): `inputs` names every row of every record's `inputs`,
/// `outputs` every row of its `outputs`, and `labels` has one entry per
/// record. Data problems (lengths, non-finite samples) are not checked here
/// but by the identifier, which returns typed errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Campaign {
    /// Sample interval, seconds.
    pub dt_s: f64,
    /// One record per hit or run.
    pub records: Vec<Record>,
    /// Input (force) channel names, in row order.
    pub inputs: Vec<String>,
    /// Output (acceleration) channel names, in DOF order.
    pub outputs: Vec<String>,
    /// One label per record: its file, or `hit k`.
    pub labels: Vec<String>,
}

impl Campaign {
    /// A campaign with default names: inputs `u1, u2, ...`, outputs
    /// `y1, y2, ...`, records `hit 1, hit 2, ...`. Panics if `records` is
    /// empty or the records' channel counts differ (a programming error:
    /// data read from files go through the `records` crate, which refuses
    /// such files with a message).
    pub fn new(records: Vec<Record>, dt_s: f64) -> Self {
        let first = records.first().expect("a campaign has at least one record");
        let (r, m) = (first.inputs.nrows(), first.outputs.nrows());
        let inputs = (1..=r).map(|i| format!("u{i}")).collect();
        let outputs = (1..=m).map(|i| format!("y{i}")).collect();
        let labels = (1..=records.len()).map(|k| format!("hit {k}")).collect();
        Self::named(records, dt_s, inputs, outputs, labels)
    }

    /// A campaign with the given names. Panics if a name list does not match
    /// the records (see the type's invariants).
    pub fn named(
        records: Vec<Record>,
        dt_s: f64,
        inputs: Vec<String>,
        outputs: Vec<String>,
        labels: Vec<String>,
    ) -> Self {
        assert_eq!(labels.len(), records.len(), "one label per record");
        for (k, rec) in records.iter().enumerate() {
            assert_eq!(
                rec.inputs.nrows(),
                inputs.len(),
                "record {k}: one name per input"
            );
            assert_eq!(
                rec.outputs.nrows(),
                outputs.len(),
                "record {k}: one name per output"
            );
        }
        Self {
            dt_s,
            records,
            inputs,
            outputs,
            labels,
        }
    }

    /// Number of records.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// True without records (only a default-constructed or emptied value).
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Samples of the longest record.
    pub fn longest(&self) -> usize {
        self.records.iter().map(Record::len).max().unwrap_or(0)
    }

    /// The campaign restricted to the records `keep` (indices, in the order
    /// given). Panics on an index out of range.
    pub fn subset(&self, keep: &[usize]) -> Campaign {
        Campaign {
            dt_s: self.dt_s,
            records: keep.iter().map(|&i| self.records[i].clone()).collect(),
            inputs: self.inputs.clone(),
            outputs: self.outputs.clone(),
            labels: keep.iter().map(|&i| self.labels[i].clone()).collect(),
        }
    }

    /// The label of record `k`, or `record k` if there is none.
    pub fn label(&self, k: usize) -> String {
        self.labels
            .get(k)
            .cloned()
            .unwrap_or_else(|| format!("record {k}"))
    }

    /// The records as one phrase for messages: the file, or
    /// `N records (first .. last)`.
    pub fn describe(&self) -> String {
        match self.labels.as_slice() {
            [one] => one.clone(),
            [first, .., last] => format!("{} records ({first} .. {last})", self.labels.len()),
            [] => "no records".into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    fn rec(n: usize) -> Record {
        Record::new(DMatrix::zeros(1, n), DMatrix::zeros(2, n))
    }

    #[test]
    fn default_names_and_subsets() {
        let c = Campaign::new(vec![rec(4), rec(6), rec(5)], 0.5);
        assert_eq!(c.inputs, ["u1"]);
        assert_eq!(c.outputs, ["y1", "y2"]);
        assert_eq!(c.describe(), "3 records (hit 1 .. hit 3)");
        assert_eq!(c.longest(), 6);
        let s = c.subset(&[2, 0]);
        assert_eq!(s.labels, ["hit 3", "hit 1"]);
        assert_eq!(s.records[0].len(), 5);
        assert_eq!(s.subset(&[1]).describe(), "hit 1");
    }

    #[test]
    #[should_panic(expected = "one name per output")]
    fn names_must_match_the_records() {
        Campaign::named(
            vec![rec(3)],
            1.0,
            vec!["f".into()],
            vec!["a".into()],
            vec!["x".into()],
        );
    }
}
