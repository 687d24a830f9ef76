//! `splatseg view`'s arguments (clap's `Args` with the `cli` feature) and their parser.

use crate::SourceOptions;
use std::path::PathBuf;

/// Open a labelled scene in the browser: see it, click objects, hide / isolate / recolour them
/// and export a selection as a PLY.
///
/// PATH is `splatseg run`'s or `train`'s output folder (e.g. `out/demo/run`), an INRIA 3DGS output
/// folder, or a file of Gaussians: any 3DGS or compressed PLY, an SPZ, a .splat or a .ksplat, chosen by content (without
/// `object_id`, which only a PLY holds, it is one object). The viewer starts at the
/// capture's first camera: the scene `run` recorded in its report.md, a `scene/` folder beside
/// PATH, or --scene. The page (HTML, JS, WebGL2 shaders) is built into the binary: no network, no
/// GPU toolkit, any browser with WebGL2.
///
/// The server listens on 127.0.0.1 only, answers only requests addressed to it (`Host`), serves
/// nothing but this scene's files, and writes exports (the same bytes as `splatseg extract` /
/// `remove`), asked for by its own page only, into --out, or PATH's folder.
/// Stop it with Ctrl-C.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct ViewArgs {
    /// Output folder of `run` / `train`, or a 3DGS PLY.
    pub path: PathBuf,
    /// Scene folder with the cameras (COLMAP or transforms.json), if not found automatically.
    #[cfg_attr(feature = "cli", arg(long))]
    pub scene: Option<PathBuf>,
    /// Address and port to listen on, `HOST:PORT` (port 0 = any free port). Any host but
    /// 127.0.0.1 / localhost exposes the scene and its export endpoint to other machines.
    #[cfg_attr(feature = "cli", arg(long, default_value = "127.0.0.1:8080", value_parser = parse_listen, value_name = "HOST:PORT"))]
    pub listen: (String, u16),
    /// Folder for exported PLYs (default: PATH's folder).
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: Option<PathBuf>,
    /// Open the page in the default browser.
    #[cfg_attr(feature = "cli", arg(long))]
    pub open: bool,
    /// A list of names, one noun per line (`#` comments and blank lines ignored): the object list
    /// shows each object's best match among them (CLIP relevancy, as `splatseg find` scores a
    /// query). Needs a run made with `--clip CKPT` (its objects/).
    #[cfg_attr(feature = "cli", arg(long, value_name = "FILE"))]
    pub names: Option<PathBuf>,
}

impl ViewArgs {
    /// Where the cameras and the exports come from.
    pub fn source_options(&self) -> SourceOptions {
        SourceOptions { scene: self.scene.clone(), out: self.out.clone() }
    }

    /// Whether the address is this machine's loopback only.
    pub fn is_loopback(&self) -> bool {
        matches!(self.listen.0.as_str(), "127.0.0.1" | "localhost" | "::1")
    }
}

/// Parses `HOST:PORT` (an IPv6 host in brackets: `[::1]:8080`).
pub fn parse_listen(text: &str) -> Result<(String, u16), String> {
    let (host, port) = text.rsplit_once(':').ok_or_else(|| format!("expected HOST:PORT, got `{text}`"))?;
    let port = port.parse::<u16>().map_err(|_| format!("`{port}` is not a port number (0–65535)"))?;
    let host = host.trim_start_matches('[').trim_end_matches(']');
    if host.is_empty() {
        return Err(format!("expected HOST:PORT, got `{text}`"));
    }
    Ok((host.to_string(), port))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn listen_takes_host_and_port_with_ipv6_in_brackets() {
        assert_eq!(parse_listen("127.0.0.1:8080"), Ok(("127.0.0.1".to_string(), 8080)));
        assert_eq!(parse_listen("[::1]:0"), Ok(("::1".to_string(), 0)));
        assert!(parse_listen("8080").is_err());
        assert!(parse_listen(":8080").is_err());
        assert!(parse_listen("localhost:http").unwrap_err().contains("not a port number"));
    }
}
