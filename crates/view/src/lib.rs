//! `view` stage: `splatseg view`, a local web viewer for a labelled 3DGS scene.
//!
//! The server ([`server`], std sockets, synchronous) serves an embedded page ([`assets`]: HTML,
//! JS, GLSL, our own) that renders the Gaussians with WebGL2 (instanced screen-space ellipses from
//! the EWA projection of `splatseg-render`, sorted back to front in a Web Worker), picks objects
//! with an id pass, hides / isolates / recolours them and exports a selection through
//! `splatseg-edit` ([`export`]).
//!
//! - [`args`]: `splatseg view`'s arguments.
//! - [`source`]: what PATH is (run / train / INRIA folder or a PLY), cameras, per-view overlays.
//! - [`pack`]: the 48-byte-per-Gaussian binary layout sent to the page.
//! - [`manifest`]: the scene description (objects by slot, cameras, views).
//! - [`routes`]: every URL of the scene (the page itself is [`request`]'s); anything else is 404.
//! - [`connections`]: the open connections and which is closed when they are too many.
//! - [`access`], [`request`], [`wire`]: who may drive the server (`Host`, the page's token and
//!   `Origin`), one request → one reply as a pure function, and HTTP/1.1 within fixed limits
//!   ([`fuzzing`] runs the whole exchange on bytes).
//! - [`editing`]: merge, split, rename in the page, previewed with `splatseg apply`'s code and
//!   saved as the run's `edits.json` (`POST /api/edits/preview`, `POST /api/edits`).
//! - [`search`]: the search box's endpoint (`/api/find?q=`), ranked by a function the caller gives.
//! - [`browser`]: a minimal WebDriver client for headless Chromium (tests, benchmarks, the
//!   README's screenshot).

pub mod access;
pub mod args;
pub mod assets;
pub mod browser;
pub mod connections;
#[cfg(test)]
mod edit_rules_tests;
pub mod editing;
pub mod error;
pub mod export;
pub mod fuzzing;
pub mod manifest;
pub mod pack;
pub mod request;
#[cfg(test)]
mod request_rules_tests;
pub mod routes;
pub mod search;
pub mod server;
pub mod source;
pub mod wire;

pub use args::ViewArgs;
pub use error::{ViewError, ViewResult};
pub use routes::Site;
pub use server::{open_in_browser, Listening, ViewServer};
pub use source::{SourceOptions, ViewSource};
