/// Why a report could not be rendered or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    /// The input contradicts itself so that it cannot be drawn honestly, e.g.
    /// a per-noise-level vector whose length differs from the number of
    /// noise levels.
    #[error("inconsistent report data in {location}: {detail}")]
    Inconsistent {
        /// Where in the report, e.g. the study, panel and quantity.
        location: String,
        /// What does not agree with what.
        detail: String,
    },
    /// Drawing a chart failed. No input is expected to cause this (odd
    /// values are drawn as well as they can be and noted); it points to a
    /// bug of this crate, such as chart groups that do not nest.
    #[error("drawing chart {chart}: {detail}")]
    Chart {
        /// Id of the chart.
        chart: String,
        /// The drawing error.
        detail: String,
    },
    /// Writing the HTML file failed (the message names it); no partial file
    /// is left.
    #[error(transparent)]
    Io(#[from] fsio::FsError),
}
