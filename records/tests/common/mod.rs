//! Helpers shared by the record tests.
#![allow(dead_code)]

/// A channel selector from its command-line text.
pub fn spec(s: &str) -> records::ChannelSpec {
    s.parse().unwrap()
}

/// The problem of a parse error and its message, which must name `file`.
pub fn parse_problem(
    file: &str,
    r: Result<records::RecordFile, records::RecordError>,
) -> (records::Problem, String) {
    use records::RecordError;
    match r {
        Err(e @ RecordError::Parse { .. }) => {
            let msg = e.to_string();
            assert!(msg.starts_with(&format!("{file}: ")), "{msg}");
            let RecordError::Parse { problem, .. } = e else {
                unreachable!()
            };
            (problem, msg)
        }
        Err(e) => panic!("not a parse error: {e}"),
        Ok(r) => panic!("accepted: {r:?}"),
    }
}
