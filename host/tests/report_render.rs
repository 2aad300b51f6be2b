//! The HTML report renders in headless Chromium with the network cut off: the zoomable
//! plotly plots are drawn (the DOM has `.js-plotly-plot` with its SVG), the page references
//! nothing on the network, and a screenshot is not blank and shows the plots' colours. The
//! test finds /usr/bin/chromium (or `chromium` on the PATH) and, as root on Debian,
//! installs it when missing.
mod cli;
#[path = "../../host-libs/model-loop/tests/common/mod.rs"]
mod common;

use cli::{tmpdir, write_log};
use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

fn chromium() -> PathBuf {
    let found = |p: &Path| {
        Command::new(p)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    };
    for c in ["/usr/bin/chromium", "chromium", "/usr/bin/chromium-browser"] {
        if found(Path::new(c)) {
            return PathBuf::from(c);
        }
    }
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| o.stdout.starts_with(b"0"));
    if root && Path::new("/usr/bin/apt-get").exists() {
        let _ = Command::new("apt-get")
            .args(["install", "-y", "-qq", "chromium"])
            .env("DEBIAN_FRONTEND", "noninteractive")
            .status();
        if found(Path::new("/usr/bin/chromium")) {
            return PathBuf::from("/usr/bin/chromium");
        }
    }
    panic!("headless Chromium is needed for this test: apt-get install -y chromium");
}

#[test]
fn diagnose_report_renders_in_headless_chromium() {
    // removed when the test ends, pass or fail, after Chromium has exited
    let tmp = tmpdir("report");
    let dir = tmp.path();
    let log = dir.join("friction.csv");
    write_log(
        &log,
        &dynamic(&DynConfig {
            dt_s: 0.01,
            duration_s: 40.0,
            hidden: Hidden::Friction { coulomb_n: 2.0 },
            seed: 4,
            ..Default::default()
        }),
        "dynamic",
    );
    let html = dir.join("report.html");
    let out = Command::new(env!("CARGO_BIN_EXE_pamctl"))
        .args([
            "model",
            "diagnose",
            log.to_str().unwrap(),
            "--report",
            html.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(
        page.contains("Plotly.newPlot") && page.contains("plotly.js v"),
        "plotly.js is embedded in the page"
    );
    assert!(page.len() < 6_000_000, "the page is {} bytes", page.len());
    // nothing outside the scripts' bodies points to the network: no external script,
    // stylesheet, image or font
    let markup = without_script_bodies(&page);
    assert!(
        !markup.contains("<svg"),
        "every plot is drawn by plotly.js in the browser, none is inline SVG"
    );
    for needle in [
        "<script src",
        "<link",
        "src=\"http",
        "src='http",
        "href=\"http",
        "url(http",
        "@import",
    ] {
        assert!(
            !markup.contains(needle),
            "the report must not load anything: found `{needle}`"
        );
    }

    let offline = [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        "--hide-scrollbars",
        // no name resolves: a page that needed the network would not draw its plots
        "--host-resolver-rules=MAP * ~NOTFOUND",
        "--virtual-time-budget=5000",
    ];
    let dom = Command::new(chromium())
        .args(offline)
        .arg(format!(
            "--user-data-dir={}",
            dir.join("profile-dom").display()
        ))
        .arg("--dump-dom")
        .arg(format!("file://{}", html.display()))
        .output()
        .unwrap();
    let dom = String::from_utf8_lossy(&dom.stdout);
    assert!(
        dom.contains("js-plotly-plot") && dom.contains("main-svg"),
        "the plotly plots did not render (DOM of {} bytes)",
        dom.len()
    );
    assert!(
        dom.matches("class=\"scatterlayer").count() >= 2,
        "both zoomable plots have their traces"
    );

    let png_path = dir.join("shot.png");
    let profile = dir.join("profile");
    let status = Command::new(chromium())
        .args(offline)
        .args([
            "--window-size=1000,2400",
            &format!("--user-data-dir={}", profile.display()),
            &format!("--screenshot={}", png_path.display()),
            &format!("file://{}", html.display()),
        ])
        .output()
        .unwrap();
    assert!(
        png_path.exists(),
        "no screenshot: {}",
        String::from_utf8_lossy(&status.stderr)
    );

    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(&png_path).unwrap(),
    ));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let bytes = &buf[..info.buffer_size()];
    let ch = info.color_type.samples();
    let (mut non_bg, mut blue, mut red, mut n) = (0usize, 0usize, 0usize, 0usize);
    for px in bytes.chunks(ch) {
        let (r, g, b) = (px[0] as i32, px[1] as i32, px[2] as i32);
        n += 1;
        if (r - 250).abs() > 12 || (g - 250).abs() > 12 || (b - 250).abs() > 12 {
            non_bg += 1;
        }
        // the plots' series colours #1f77b4 and #d62728
        if (r - 0x1f).abs() < 40 && (g - 0x77).abs() < 40 && (b - 0xb4).abs() < 40 {
            blue += 1;
        }
        if (r - 0xd6).abs() < 40 && (g - 0x27).abs() < 40 && (b - 0x28).abs() < 40 {
            red += 1;
        }
    }
    assert!(
        n > 100_000,
        "screenshot too small: {}×{}",
        info.width,
        info.height
    );
    assert!(
        non_bg as f64 > 0.03 * n as f64,
        "screenshot is blank: {non_bg} of {n} pixels differ from the background"
    );
    assert!(
        blue > 200 && red > 200,
        "plot colours missing: blue {blue}, red {red}"
    );
}

/// The page with the text between `<script…>` and `</script>` removed (the embedded
/// library's own strings are not references of the page).
fn without_script_bodies(page: &str) -> String {
    let mut out = String::new();
    let mut rest = page;
    while let Some(i) = rest.find("<script") {
        let Some(gt) = rest[i..].find('>') else {
            break;
        };
        out.push_str(&rest[..i + gt + 1]);
        match rest[i + gt..].find("</script>") {
            Some(e) => rest = &rest[i + gt + e..],
            None => {
                rest = "";
            }
        }
    }
    out.push_str(rest);
    out
}
