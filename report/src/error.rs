//! The one error type of `report`.

use std::path::PathBuf;

use thiserror::Error;

/// A plot could not be drawn, or (feature `browser`) a page could not be checked.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ReportError {
    /// A drawing error, with the plot's title.
    #[error("plot '{plot}': {message}")]
    Plot {
        /// Plot title.
        plot: String,
        /// The drawing error.
        message: String,
    },
    /// The browser could not be started or did not answer.
    #[error("browser: {0}")]
    Browser(BrowserFault),
}

/// What went wrong with the browser of a page check. Foreign errors (I/O,
/// JSON, image decoding, the DevTools protocol's own error objects) are kept
/// as their text, so that the error stays `Clone` and `PartialEq` for the
/// crates that embed it.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BrowserFault {
    /// No browser, and the environment requires one.
    #[error("TRINOCULAR_REQUIRE_BROWSER=1 but no chromium on the PATH (apt-get install chromium)")]
    Required,
    /// The browser could not be started.
    #[error("starting {}: {reason}", browser.display())]
    Start {
        /// The browser's path.
        browser: PathBuf,
        /// Why.
        reason: String,
    },
    /// A FIFO to talk to the browser could not be made.
    #[error("mkfifo {} failed", .0.display())]
    Fifo(PathBuf),
    /// A command could not be encoded.
    #[error("{0}")]
    Encode(String),
    /// A command could not be written to the browser.
    #[error("writing to the browser: {0}")]
    Write(String),
    /// The browser answered a command with an error.
    #[error("{method} failed: {error}")]
    Refused {
        /// The DevTools method.
        method: String,
        /// The browser's error object.
        error: String,
    },
    /// No answer to a command in time.
    #[error("no answer to {method}; its stderr:\n{stderr}")]
    NoAnswer {
        /// The DevTools method.
        method: String,
        /// The end of the browser's stderr.
        stderr: String,
    },
    /// An awaited event did not come in time.
    #[error("no {event}; its stderr:\n{stderr}")]
    NoEvent {
        /// The DevTools event.
        event: String,
        /// The end of the browser's stderr.
        stderr: String,
    },
    /// The page session was not attached.
    #[error("no session id")]
    NoSession,
    /// No data (screenshot or PDF) in the answer.
    #[error("no data in the browser's answer (screenshot or PDF)")]
    NoData,
    /// The answer's data is not base64.
    #[error("the browser's screenshot or PDF is not base64: {0}")]
    NotBase64(String),
    /// The screenshot is not an image.
    #[error("screenshot: {0}")]
    Screenshot(String),
    /// The page's layout script returned nothing.
    #[error("no layout")]
    NoLayout,
    /// The page's layout is not the JSON expected.
    #[error("layout: {0}")]
    Layout(String),
}

/// Result alias for `report`.
pub type Result<T> = std::result::Result<T, ReportError>;
