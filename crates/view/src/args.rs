//! `splatseg view`'s arguments (clap's `Args` with the `cli` feature) and their parser.

use crate::SourceOptions;
use std::path::PathBuf;

/// Open a labelled scene in the browser: see it, click objects, hide / isolate / recolour them,
/// export a selection, a box crop or the scene coloured by object as a PLY, and fix a run's objects: merge, split by a box or a lasso,
/// paint Gaussians with a brush, grow or shrink that selection by 3D neighbours and move it to an object, rename,
/// undo, redo, and Save them as the run's edits.json for `splatseg apply`.
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
/// `remove`), asked for by its own page only, into --out, or PATH's folder; an export never
/// replaces a file there (`extract_3.ply` taken: `extract_3-2.ply`).
///
/// Editing is on when PATH is a run's output folder (or its gaussians.ply): every edit is shown at
/// once as `splatseg apply` will make it, and Save writes PATH/edits.json (only from the viewer's
/// own page; never over an edits.json of another run or one changed on disk meanwhile); the page
/// starts from the run's edits.json when there is one. Then run `splatseg apply PATH`.
/// Stop it with Ctrl-C.
#[derive(Debug)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct ViewArgs {
    /// Output folder of `run` / `train`, or a 3DGS PLY.
    pub path: PathBuf,
    /// Scene folder with the cameras (COLMAP or transforms.json), if not found automatically.
    #[cfg_attr(feature = "cli", arg(long))]
    pub scene: Option<PathBuf>,
    /// Address and port to listen on, `HOST:PORT` (port 0 = any free port; an IPv6 address in
    /// brackets, `[::1]:8080`). A host other than a loopback address exposes the scene and its
    /// export endpoint to other machines.
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
}

/// Parses `HOST:PORT`: a name or an IPv4 address, or an IPv6 address in brackets (`[::1]:8080`).
/// Whether the host resolves is checked when the server binds, before it says anything.
pub fn parse_listen(text: &str) -> Result<(String, u16), String> {
    let expected = || {
        format!("expected HOST:PORT such as 127.0.0.1:8080 (an IPv6 address in brackets: [::1]:8080), got `{text}`")
    };
    let (host, port) = text.rsplit_once(':').ok_or_else(expected)?;
    let port =
        port.parse::<u16>().map_err(|_| format!("`{port}` is not a port number (0–65535) in `{text}`"))?;
    let host = match host.strip_prefix('[') {
        Some(bracketed) => {
            let inner = bracketed.strip_suffix(']').ok_or_else(expected)?;
            inner
                .parse::<std::net::Ipv6Addr>()
                .map_err(|_| format!("`[{inner}]` is not an IPv6 address in `{text}`"))?;
            inner
        }
        // `127.0.0.1:80:80`, `::1:8080`: a second `:` outside brackets
        None if host.contains([':', '[', ']']) => return Err(expected()),
        None => host,
    };
    if host.is_empty() {
        return Err(expected());
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

    #[test]
    fn listen_refuses_a_second_colon_and_bad_brackets() {
        for bad in
            ["127.0.0.1:80:80", "::1:8080", "[::1:8080", "::1]:8080", "[]:80", "[nohost]:80", "a[b]:80"]
        {
            let err = parse_listen(bad).expect_err(bad);
            assert!(err.contains(&format!("`{bad}`")) || err.contains("IPv6 address"), "{bad}: {err}");
        }
        assert!(parse_listen("127.0.0.1:80:80").unwrap_err().contains("expected HOST:PORT"));
        assert_eq!(parse_listen("[fe80::1]:9"), Ok(("fe80::1".to_string(), 9)));
        assert_eq!(parse_listen("viewer.local:0"), Ok(("viewer.local".to_string(), 0)));
    }
}
