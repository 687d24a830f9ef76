//! The WebDriver commands we use, against chromedriver driving headless Chromium.

use super::http::request;
use crate::error::{ViewError, ViewResult};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The W3C key of an element reference in WebDriver JSON.
const ELEMENT_KEY: &str = "element-6066-11e4-a52e-4f735466cecf";

/// Where Chromium and chromedriver are.
#[derive(Clone, Debug)]
pub struct ChromiumPaths {
    /// The browser.
    pub chromium: PathBuf,
    /// The driver.
    pub chromedriver: PathBuf,
}

fn on_path(names: &[&str]) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path).flat_map(|dir| names.iter().map(move |n| dir.join(n))).find(|p| p.is_file())
}

/// Chromium and chromedriver from `SPLATSEG_CHROMIUM` / `SPLATSEG_CHROMEDRIVER` or `PATH`
/// (`chromium`, `chromium-browser`, `google-chrome`; `chromedriver`), or `None`.
pub fn find_chromium() -> Option<ChromiumPaths> {
    let from_env = |k: &str| std::env::var_os(k).map(PathBuf::from).filter(|p| p.is_file());
    let chromium = from_env("SPLATSEG_CHROMIUM")
        .or_else(|| on_path(&["chromium", "chromium-browser", "google-chrome"]))?;
    let chromedriver = from_env("SPLATSEG_CHROMEDRIVER").or_else(|| on_path(&["chromedriver"]))?;
    Some(ChromiumPaths { chromium, chromedriver })
}

fn err(message: impl Into<String>) -> ViewError {
    ViewError::Browser(message.into())
}

/// A headless Chromium session (chromedriver child process + a fresh profile folder).
pub struct Browser {
    driver: Child,
    base: String,
    session: String,
    profile: PathBuf,
}

impl Browser {
    /// Starts chromedriver and a headless Chromium with software WebGL and a `width × height`
    /// window.
    pub fn launch(paths: &ChromiumPaths, width: u32, height: u32) -> ViewResult<Browser> {
        let port = free_port()?;
        let profile = std::env::temp_dir().join(format!("splatseg-chromium-{}-{port}", std::process::id()));
        std::fs::create_dir_all(&profile)
            .map_err(|e| err(format!("cannot create {}: {e}", profile.display())))?;
        let driver = Command::new(&paths.chromedriver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| err(format!("cannot start {}: {e}", paths.chromedriver.display())))?;
        let mut browser =
            Browser { driver, base: format!("http://127.0.0.1:{port}"), session: String::new(), profile };
        browser.wait_until_ready()?;
        let args = [
            "--headless".to_string(),
            "--no-sandbox".to_string(),
            "--disable-gpu".to_string(),
            "--use-angle=swiftshader".to_string(),
            "--enable-unsafe-swiftshader".to_string(),
            "--disable-background-networking".to_string(),
            "--disable-component-update".to_string(),
            "--disable-sync".to_string(),
            "--disable-quic".to_string(),
            "--no-first-run".to_string(),
            "--disable-dev-shm-usage".to_string(),
            format!("--user-data-dir={}", browser.profile.display()),
            format!("--window-size={width},{height}"),
        ];
        let caps = json!({ "capabilities": { "alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": { "binary": paths.chromium.display().to_string(), "args": args }
        }}});
        let value = browser.call("POST", "/session", Some(caps))?;
        browser.session =
            value["sessionId"].as_str().ok_or_else(|| err(format!("no session id in {value}")))?.to_string();
        browser.call(
            "POST",
            &browser.path("/timeouts"),
            Some(json!({ "script": 600_000, "pageLoad": 60_000 })),
        )?;
        Ok(browser)
    }

    fn wait_until_ready(&self) -> ViewResult<()> {
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(20) {
            if let Ok(r) = request("GET", &format!("{}/status", self.base), None, Duration::from_secs(5)) {
                if r.status == 200 {
                    return Ok(());
                }
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        Err(err("chromedriver did not start within 20 s"))
    }

    fn path(&self, suffix: &str) -> String {
        format!("/session/{}{suffix}", self.session)
    }

    /// One WebDriver command; returns its `value`.
    fn call(&self, method: &str, path: &str, body: Option<Value>) -> ViewResult<Value> {
        let bytes = body.map(|b| b.to_string().into_bytes());
        let url = format!("{}{path}", self.base);
        let r = request(method, &url, bytes.as_deref(), Duration::from_secs(660)).map_err(err)?;
        let value: Value = serde_json::from_slice(&r.body)
            .map_err(|e| err(format!("WebDriver answered {} with no JSON ({e})", r.status)))?;
        if r.status != 200 {
            return Err(err(format!("WebDriver {method} {path}: {} {}", r.status, value["value"])));
        }
        Ok(value["value"].clone())
    }

    /// Opens `url`.
    pub fn goto(&self, url: &str) -> ViewResult<()> {
        self.call("POST", &self.path("/url"), Some(json!({ "url": url }))).map(|_| ())
    }

    /// Runs `script` (a function body; `arguments[i]` are `args`) and returns its value.
    pub fn execute(&self, script: &str, args: Value) -> ViewResult<Value> {
        self.call("POST", &self.path("/execute/sync"), Some(json!({ "script": script, "args": args })))
    }

    /// Runs `script` whose last argument is a callback to call with the result (for promises).
    pub fn execute_async(&self, script: &str, args: Value) -> ViewResult<Value> {
        self.call("POST", &self.path("/execute/async"), Some(json!({ "script": script, "args": args })))
    }

    /// Awaits the promise `expression` (e.g. `viewer.whenReady()`), returning what it resolves to;
    /// a rejection becomes `{"error": message}`.
    pub fn await_promise(&self, expression: &str) -> ViewResult<Value> {
        let script = format!(
            "const done = arguments[arguments.length - 1]; Promise.resolve({expression}).then(done, e => done({{ error: String(e) }}));"
        );
        self.execute_async(&script, json!([]))
    }

    /// Clicks with the mouse at pixel `(x, y)` of the element matching `css` (CSS pixels from its
    /// top-left corner).
    pub fn click_at(&self, css: &str, x: f64, y: f64) -> ViewResult<()> {
        let found = self.call(
            "POST",
            &self.path("/element"),
            Some(json!({ "using": "css selector", "value": css })),
        )?;
        let element =
            found[ELEMENT_KEY].as_str().ok_or_else(|| err(format!("no element `{css}`")))?.to_string();
        let rect = self.call("GET", &self.path(&format!("/element/{element}/rect")), None)?;
        let (w, h) = (rect["width"].as_f64().unwrap_or(0.0), rect["height"].as_f64().unwrap_or(0.0));
        // Actions with an element origin are offsets from the element's centre (whole CSS px).
        let (dx, dy) = ((x - (w / 2.0).floor()).floor() as i64, (y - (h / 2.0).floor()).floor() as i64);
        let actions = json!({ "actions": [{
            "type": "pointer", "id": "mouse", "parameters": { "pointerType": "mouse" },
            "actions": [
                { "type": "pointerMove", "duration": 0, "origin": { ELEMENT_KEY: element }, "x": dx, "y": dy },
                { "type": "pointerDown", "button": 0 },
                { "type": "pointerUp", "button": 0 }
            ]
        }]});
        self.call("POST", &self.path("/actions"), Some(actions))?;
        self.call("DELETE", &self.path("/actions"), None).map(|_| ())
    }

    /// A PNG of the browser window.
    pub fn screenshot_png(&self) -> ViewResult<Vec<u8>> {
        let value = self.call("GET", &self.path("/screenshot"), None)?;
        super::base64::decode(value.as_str().unwrap_or("")).map_err(err)
    }

    /// The profile folder (removed on drop).
    pub fn profile(&self) -> &Path {
        &self.profile
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if !self.session.is_empty() {
            let _ = self.call("DELETE", &format!("/session/{}", self.session), None);
        }
        let _ = self.driver.kill();
        let _ = self.driver.wait();
        let _ = std::fs::remove_dir_all(&self.profile);
    }
}

fn free_port() -> ViewResult<u16> {
    let listener =
        std::net::TcpListener::bind("127.0.0.1:0").map_err(|e| err(format!("no free port: {e}")))?;
    listener.local_addr().map(|a| a.port()).map_err(|e| err(format!("no free port: {e}")))
}
