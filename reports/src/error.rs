use std::path::PathBuf;

/// Why a report could not be rendered or written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The input contradicts itself so that it cannot be drawn honestly, e.g.
    /// a per-noise-level vector whose length differs from the number of
    /// noise levels.
    #[error("inconsistent report data in {location}: {detail}")]
    Inconsistent { location: String, detail: String },
    /// The chart library failed (not expected with the in-memory SVG
    /// backend).
    #[error("drawing chart {chart}: {detail}")]
    Chart { chart: String, detail: String },
    /// Writing the HTML file failed; no partial file is left at `path`.
    #[error("writing report to {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}
