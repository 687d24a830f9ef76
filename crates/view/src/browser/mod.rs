//! Driving a real headless Chromium from Rust over WebDriver (chromedriver), with no Node and no
//! async runtime: a minimal HTTP/1.1 client ([`http`]) and the handful of WebDriver commands the
//! browser test, the benchmarks and the README screenshot need ([`webdriver`]).
//!
//! Chromium runs with software WebGL (SwiftShader): `--headless --use-angle=swiftshader
//! --enable-unsafe-swiftshader --disable-gpu`, `--no-sandbox` (needed as root), no background
//! networking, a fresh profile folder removed afterwards. Debian: `apt-get install chromium
//! chromium-driver`; [`find_chromium`] looks for them on `PATH` (or `SPLATSEG_CHROMIUM` /
//! `SPLATSEG_CHROMEDRIVER`).

pub mod base64;
pub mod http;
pub mod webdriver;

pub use webdriver::{find_chromium, Browser, ChromiumPaths};
