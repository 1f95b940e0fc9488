//! `cpg view` in a real browser: the page is opened in headless Chromium
//! (Debian's package; `.ci/run` installs it), driven through the DevTools
//! protocol over a pipe, played, paused and scrubbed with real input events,
//! and its screenshots are checked: figures drawn, frames changing while it
//! plays, still while paused. The GIF is decoded and checked the same way.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use std::ffi::OsStr;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

mod common;

use common::{cmu, cpg, ok, walk22};

/// Debian's Chromium, or `$CPG_CHROMIUM`.
fn chromium() -> PathBuf {
    if let Some(p) = std::env::var_os("CPG_CHROMIUM") {
        return PathBuf::from(p);
    }
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        for dir in std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default()) {
            let p = dir.join(name);
            if p.is_file() {
                return p;
            }
        }
    }
    panic!(
        "no Chromium found: install Debian's package (apt-get install chromium; .ci/run does) or set CPG_CHROMIUM to a Chromium binary"
    );
}

/// A headless Chromium driven through the DevTools protocol on a pipe
/// (`--remote-debugging-pipe`: commands on its fd 3, answers on its fd 4,
/// each message JSON ended by a NUL byte).
struct Browser {
    child: Child,
    to: ChildStdin,
    from: Receiver<Value>,
    next_id: u64,
    session: String,
    _profile: tempfile::TempDir,
}

impl Browser {
    fn start() -> Browser {
        Browser::start_with(&["--hide-scrollbars"])
    }

    /// A browser with `extra` flags beside the ones every test uses.
    fn start_with(extra: &[&str]) -> Browser {
        let profile = tempfile::tempdir().unwrap();
        let mut flags = vec![
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-quic",
            "--no-first-run",
            "--remote-debugging-pipe",
        ];
        flags.extend_from_slice(extra);
        // The shell hands our pipes to Chromium as fds 3 and 4.
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(r#"exec "$0" "$@" 3<&0 4>&1 0</dev/null 1>/dev/null 2>/dev/null"#)
            .arg(chromium())
            .args(flags)
            .arg(format!("--user-data-dir={}", profile.path().display()))
            .arg("about:blank")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let to = child.stdin.take().unwrap();
        let out = child.stdout.take().unwrap();
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            let mut r = BufReader::new(out);
            loop {
                let mut buf = Vec::new();
                match r.read_until(0, &mut buf) {
                    Ok(0) | Err(_) => return,
                    Ok(_) => {
                        buf.pop();
                        if let Ok(v) = serde_json::from_slice::<Value>(&buf)
                            && tx.send(v).is_err()
                        {
                            return;
                        }
                    }
                }
            }
        });
        let mut b = Browser { child, to, from: rx, next_id: 0, session: String::new(), _profile: profile };
        let target = b.call("Target.createTarget", json!({"url": "about:blank"}));
        let id = target["targetId"].as_str().unwrap().to_owned();
        let att = b.call("Target.attachToTarget", json!({"targetId": id, "flatten": true}));
        b.session = att["sessionId"].as_str().unwrap().to_owned();
        b
    }

    /// Sends a command (to the page once attached) and waits for its answer.
    fn call(&mut self, method: &str, params: Value) -> Value {
        self.next_id += 1;
        let id = self.next_id;
        let mut msg = json!({"id": id, "method": method, "params": params});
        if !self.session.is_empty() {
            msg["sessionId"] = json!(self.session);
        }
        let mut bytes = serde_json::to_vec(&msg).unwrap();
        bytes.push(0);
        self.to.write_all(&bytes).unwrap();
        self.to.flush().unwrap();
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.from.recv_timeout(left) {
                Ok(v) if v["id"] == json!(id) => {
                    assert!(v.get("error").is_none(), "{method}: {}", v["error"]);
                    return v["result"].clone();
                }
                Ok(_) => {}
                Err(RecvTimeoutError::Timeout) => panic!("{method}: no answer from Chromium in 60 s"),
                Err(RecvTimeoutError::Disconnected) => panic!("{method}: Chromium closed the pipe"),
            }
        }
    }

    /// Evaluates a JavaScript expression in the page; its value as JSON.
    fn eval(&mut self, expr: &str) -> Value {
        let r = self.call("Runtime.evaluate", json!({"expression": expr, "returnByValue": true}));
        assert!(r.get("exceptionDetails").is_none(), "{expr}: {}", r["exceptionDetails"]);
        r["result"]["value"].clone()
    }

    fn open(&mut self, file: &Path) {
        self.open_at(file, 1300, 800);
    }

    /// Opens `file` in a window of `width` × `height` CSS pixels.
    fn open_at(&mut self, file: &Path, width: u32, height: u32) {
        self.call(
            "Emulation.setDeviceMetricsOverride",
            json!({"width": width, "height": height, "deviceScaleFactor": 1, "mobile": false}),
        );
        let url = format!("file://{}", file.canonicalize().unwrap().display());
        self.call("Page.navigate", json!({"url": url}));
        let deadline = Instant::now() + Duration::from_secs(30);
        while self.eval("document.readyState === 'complete' && typeof window.cpgView === 'object'") != json!(true) {
            assert!(Instant::now() < deadline, "the page did not load in 30 s");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    fn screenshot(&mut self) -> Image {
        let r = self.call("Page.captureScreenshot", json!({"format": "png"}));
        Image::png(&base64(r["data"].as_str().unwrap()))
    }

    /// A real mouse click at the centre of the element `selector`.
    fn click(&mut self, selector: &str) {
        let r = self.eval(&format!(
            "(() => {{ const r = document.querySelector('{selector}').getBoundingClientRect(); return [r.x + r.width / 2, r.y + r.height / 2]; }})()"
        ));
        let (x, y) = (r[0].as_f64().unwrap(), r[1].as_f64().unwrap());
        for kind in ["mousePressed", "mouseReleased"] {
            self.call(
                "Input.dispatchMouseEvent",
                json!({"type": kind, "x": x, "y": y, "button": "left", "clickCount": 1}),
            );
        }
    }

    fn key(&mut self, key: &str, code: &str, key_code: u32) {
        for kind in ["keyDown", "keyUp"] {
            self.call(
                "Input.dispatchKeyEvent",
                json!({"type": kind, "key": key, "code": code, "windowsVirtualKeyCode": key_code}),
            );
        }
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn base64(s: &str) -> Vec<u8> {
    let val = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let clean: Vec<u8> = s.bytes().filter(|&c| c != b'=' && !c.is_ascii_whitespace()).collect();
    let mut out = Vec::with_capacity(clean.len() * 3 / 4);
    for chunk in clean.chunks(4) {
        let mut v = 0u32;
        for (k, &c) in chunk.iter().enumerate() {
            v |= u32::from(val(c)) << (18 - 6 * k);
        }
        out.extend(v.to_be_bytes()[1..chunk.len()].iter());
    }
    out
}

/// RGB pixels.
#[derive(PartialEq)]
struct Image {
    w: usize,
    h: usize,
    rgb: Vec<u8>,
}

impl Image {
    fn png(bytes: &[u8]) -> Image {
        let mut d = png::Decoder::new(std::io::Cursor::new(bytes));
        d.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
        let mut r = d.read_info().unwrap();
        let mut buf = vec![0; r.output_buffer_size()];
        let info = r.next_frame(&mut buf).unwrap();
        let ch = info.color_type.samples();
        let rgb = buf[..info.buffer_size()].chunks(ch).flat_map(|p| [p[0], p[1], p[2]]).collect();
        Image { w: info.width as usize, h: info.height as usize, rgb }
    }

    /// Pixels within a small distance of `color` inside the box `[x0, x1) × [y0, y1)`.
    fn count(&self, color: [u8; 3], x0: usize, x1: usize, y0: usize, y1: usize) -> usize {
        let mut n = 0;
        for y in y0..y1.min(self.h) {
            for x in x0..x1.min(self.w) {
                let p = &self.rgb[(y * self.w + x) * 3..(y * self.w + x) * 3 + 3];
                if p.iter().zip(color).all(|(a, b)| (i32::from(*a) - i32::from(b)).abs() <= 24) {
                    n += 1;
                }
            }
        }
        n
    }

    /// Pixels that differ from `other` inside the box.
    fn differ(&self, other: &Image, x0: usize, x1: usize, y0: usize, y1: usize) -> usize {
        let mut n = 0;
        for y in y0..y1.min(self.h) {
            for x in x0..x1.min(self.w) {
                let k = (y * self.w + x) * 3;
                if self.rgb[k..k + 3] != other.rgb[k..k + 3] {
                    n += 1;
                }
            }
        }
        n
    }
}

const LEFT: [u8; 3] = [31, 111, 209];
const RIGHT: [u8; 3] = [214, 64, 48];

#[test]
fn the_page_plays_pauses_and_scrubs_in_a_real_browser_and_shows_every_figure() {
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("view.html");
    let err = ok(&cpg(&[
        OsStr::new("view"),
        "-m".as_ref(),
        walk22().as_os_str(),
        "--seconds".as_ref(),
        "4".as_ref(),
        "-o".as_ref(),
        html.as_os_str(),
    ]));
    assert!(err.contains("480 frames") && err.contains("teacher, model, HOAP-2"), "{err}");
    let page = std::fs::read_to_string(&html).unwrap();
    // Self-contained: no address of anything outside the file.
    for outside in ["http:", "https:", "src=", "href=", "@import", "url("] {
        assert!(!page.contains(outside), "the page refers to something outside itself ({outside})");
    }

    let mut b = Browser::start();
    b.open(&html);
    assert_eq!(b.eval("cpgView.figures"), json!(3));
    assert_eq!(b.eval("cpgView.n_frames"), json!(480));
    let panels = b.eval(
        "Array.from(document.querySelectorAll('canvas')).map(c => { const r = c.getBoundingClientRect(); return [r.x, r.y, r.width, r.height]; })",
    );
    let panels: Vec<[usize; 4]> = panels
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let v: Vec<usize> = p.as_array().unwrap().iter().map(|x| x.as_f64().unwrap() as usize).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect();
    assert_eq!(panels.len(), 3);

    // It plays on its own: frames advance and the pictures change.
    std::thread::sleep(Duration::from_millis(300));
    let (f0, a) = (b.eval("cpgView.frame").as_u64().unwrap(), b.screenshot());
    std::thread::sleep(Duration::from_millis(700));
    let (f1, c) = (b.eval("cpgView.frame").as_u64().unwrap(), b.screenshot());
    assert_ne!(f0, f1, "the frame did not advance while playing");
    for (k, p) in panels.iter().enumerate() {
        let (x0, x1, y0, y1) = (p[0], p[0] + p[2], p[1], p[1] + p[3]);
        // Each panel shows a figure: both sides' limbs in their colours.
        for (img, when) in [(&a, "first"), (&c, "second")] {
            let (l, r) = (img.count(LEFT, x0, x1, y0, y1), img.count(RIGHT, x0, x1, y0, y1));
            assert!(l > 150 && r > 150, "panel {k}, {when} screenshot: {l} left-limb and {r} right-limb pixels");
        }
        let moved = a.differ(&c, x0, x1, y0, y1);
        assert!(moved > 200, "panel {k}: only {moved} pixels changed in 0.7 s of playing");
    }

    // A real click on the button pauses it: nothing moves any more.
    b.click("#play");
    assert_eq!(b.eval("cpgView.playing"), json!(false));
    assert_eq!(b.eval("document.getElementById('play').textContent"), json!("Play"));
    let (g0, d) = (b.eval("cpgView.frame"), b.screenshot());
    std::thread::sleep(Duration::from_millis(500));
    let (g1, e) = (b.eval("cpgView.frame"), b.screenshot());
    assert_eq!(g0, g1, "the frame advanced while paused");
    assert!(d == e, "the picture changed while paused");

    // The arrow key steps one frame; the slider scrubs.
    b.key("ArrowRight", "ArrowRight", 39);
    assert_eq!(b.eval("cpgView.frame").as_u64().unwrap(), (g1.as_u64().unwrap() + 1) % 480);
    b.eval(
        "(() => { const s = document.getElementById('time'); s.value = 240; s.dispatchEvent(new Event('input')); })()",
    );
    assert_eq!(b.eval("cpgView.frame"), json!(240));
    assert_eq!(b.eval("document.getElementById('clock').textContent"), json!("2.00 s / 4.00 s"));
    let f = b.screenshot();
    assert!(f.differ(&e, 0, f.w, 0, f.h) > 200, "scrubbing to 2 s did not change the picture");

    // Space plays again.
    b.key(" ", "Space", 32);
    assert_eq!(b.eval("cpgView.playing"), json!(true));
    std::thread::sleep(Duration::from_millis(400));
    assert_ne!(b.eval("cpgView.frame"), json!(240), "space did not resume playing");
}

#[test]
fn the_gif_loops_in_real_time_and_shows_every_figure_moving() {
    let dir = tempfile::tempdir().unwrap();
    let gif_path = dir.path().join("view.gif");
    let err = ok(&cpg(&[
        OsStr::new("view"),
        "-m".as_ref(),
        walk22().as_os_str(),
        "--seconds".as_ref(),
        "3".as_ref(),
        "--gif-seconds".as_ref(),
        "2".as_ref(),
        "-o".as_ref(),
        gif_path.as_os_str(),
    ]));
    assert!(err.contains("animated GIF"), "{err}");
    let bytes = std::fs::read(&gif_path).unwrap();
    assert!(bytes.starts_with(b"GIF89a"));
    let mut opts = gif::DecodeOptions::new();
    opts.set_color_output(gif::ColorOutput::RGBA);
    let mut d = opts.read_info(std::io::Cursor::new(&bytes)).unwrap();
    let (w, h) = (usize::from(d.width()), usize::from(d.height()));
    assert_eq!((w, h), (3 * 320, 400), "three panels of 320 × 400");
    let mut frames = Vec::new();
    let mut delay_cs = 0u32;
    while let Some(f) = d.read_next_frame().unwrap() {
        delay_cs += u32::from(f.delay);
        let rgb: Vec<u8> = f.buffer.chunks(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
        frames.push(Image { w, h, rgb });
    }
    assert_eq!(frames.len(), 50, "2 s at 25 frames per second");
    assert_eq!(delay_cs, 200, "the delays add up to the 2 s shown");
    for k in 0..3 {
        let (x0, x1) = (k * 320, (k + 1) * 320);
        let first = &frames[0];
        assert!(first.count(LEFT, x0, x1, 0, h) > 100 && first.count(RIGHT, x0, x1, 0, h) > 100, "panel {k}");
        let moved = first.differ(&frames[12], x0, x1, 0, h);
        assert!(moved > 200, "panel {k}: {moved} pixels changed in 0.48 s");
    }
}

#[test]
fn a_recording_is_shown_beside_the_robot_it_drives_and_bad_requests_say_why() {
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("rec.html");
    let err = ok(&cpg(&[
        OsStr::new("view"),
        "--motion".as_ref(),
        cmu("35_01.amc").as_os_str(),
        "--skeleton".as_ref(),
        cmu("35.asf").as_os_str(),
        "-o".as_ref(),
        html.as_os_str(),
    ]));
    // 35_01 is 358 frames: shorter than the default 10 s.
    assert!(err.contains("358 frames") && err.contains("recording, HOAP-2"), "{err}");
    let o = cpg(&[OsStr::new("view"), "-o".as_ref(), html.as_os_str()]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("give --model"));
    let o = cpg(&[
        OsStr::new("view"),
        "-m".as_ref(),
        walk22().as_os_str(),
        "--format".as_ref(),
        "png".as_ref(),
        "-o".as_ref(),
        html.as_os_str(),
    ]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("expected html"));
    let o = cpg(&[
        OsStr::new("view"),
        "-m".as_ref(),
        walk22().as_os_str(),
        "--fps".as_ref(),
        "0".as_ref(),
        "-o".as_ref(),
        dir.path().join("x.gif").as_os_str(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("frames per second"), "{e}");
    assert!(!dir.path().join("x.gif").exists(), "nothing is written on an error");
}

/// Names come from the user's files: a joint named to break out of the page
/// (`<!--<script>`, `</script>`) is shown as text, and the page still runs.
#[test]
fn hostile_joint_names_are_text_and_the_page_still_runs() {
    let dir = tempfile::tempdir().unwrap();
    let bvh = dir.path().join("hostile.bvh");
    let mut text = String::from(
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n  JOINT <!--<script>\n  {\n    OFFSET 0 -90 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 0 -90 0\n    }\n  }\n  JOINT </script><b>&amp;\n  {\n    OFFSET 0 40 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 0 30 0\n    }\n  }\n}\nMOTION\nFrames: 30\nFrame Time: 0.0333333\n",
    );
    for k in 0..30 {
        let a = 20.0 * (k as f64 * 0.2).sin();
        text.push_str(&format!("0 180 {} 0 0 0 0 {a:.3} 0 0 {:.3} 0\n", k as f64, -a));
    }
    std::fs::write(&bvh, text).unwrap();
    let html = dir.path().join("hostile.html");
    ok(&cpg(&[
        OsStr::new("view"),
        "--motion".as_ref(),
        bvh.as_os_str(),
        "--no-robot".as_ref(),
        "-o".as_ref(),
        html.as_os_str(),
    ]));
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(!page.contains("<!--<script>") && !page.contains("</script><b>"), "a name reached the page's markup raw");
    let mut b = Browser::start();
    b.open(&html);
    assert_eq!(b.eval("cpgView.figures"), json!(1), "the page's script did not run");
    let names = b.eval("JSON.parse(document.getElementById('scene').textContent).figures[0].names.join('|')");
    let names = names.as_str().unwrap();
    assert!(names.contains("<!--<script>") && names.contains("</script><b>&amp;"), "{names}");
    assert_eq!(b.eval("document.querySelectorAll('script').length"), json!(2), "no script element was injected");
}

/// A run of the HOAP-2 in MuJoCo (`cpg-sim -o`) is shown where the physics
/// put the body; a file that is not such a run says where.
#[test]
fn a_simulated_run_is_shown_where_the_physics_put_the_body() {
    let dir = tempfile::tempdir().unwrap();
    let robot = cpg_robot::Robot::hoap2().unwrap();
    let joints: Vec<String> = robot.joints.iter().map(|j| j.name.clone()).collect();
    // The trunk walks 0.1 m forward in 2 s (50 Hz), a knee bent.
    let poses: Vec<Vec<f64>> = (0..100)
        .map(|k| {
            let t = k as f64 / 50.0;
            let mut p = vec![t, 0.05 * t, 0.0, 0.3, 1.0, 0.0, 0.0, 0.0];
            p.extend(joints.iter().map(|j| if j == "lleg_joint_4" { 0.5 } else { 0.0 }));
            p
        })
        .collect();
    let run = json!({
        "seconds": 2.0, "upright_s": 2.0, "fell": false, "forward_m": 0.1, "lateral_m": 0.0,
        "heading_deg": 0.0, "speed_m_s": 0.05, "speed_leg_lengths_s": 0.2, "max_torque_nm": 1.0,
        "cost_of_transport": 1.0, "pushes_survived": 0, "pushes_total": 0,
        "pose_joints": joints, "poses": poses,
    });
    let sim = dir.path().join("run.json");
    std::fs::write(&sim, run.to_string()).unwrap();
    let out = dir.path().join("run.html");
    let err = ok(&cpg(&[
        OsStr::new("view"),
        "--sim".as_ref(),
        sim.as_os_str(),
        "--seconds".as_ref(),
        "1".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
    ]));
    assert!(err.contains("50 frames") && err.contains("HOAP-2"), "{err}");
    assert!(std::fs::read_to_string(&out).unwrap().contains("simulated in MuJoCo"));
    std::fs::write(&sim, "{\n \"upright_s\": \"long\"\n}").unwrap();
    let o = cpg(&[OsStr::new("view"), "--sim".as_ref(), sim.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("run.json:2") && err.contains("not a cpg-sim run"), "{err}");
}

/// A scene's marks (the whole body's state switches) in the browser: a tick
/// on the slider and a button each; a real click on a button pauses and jumps
/// there, and the clock names the state the frame is in.
#[test]
fn the_marks_on_the_timeline_jump_to_their_moment_and_name_it() {
    let dir = tempfile::tempdir().unwrap();
    let asf = std::fs::read(cmu("35.asf")).unwrap();
    let sk = cpg_mocap::parse_asf("35.asf", &asf).unwrap();
    let amc = std::fs::read(cmu("35_01.amc")).unwrap();
    let motion = cpg_mocap::parse_amc("35_01.amc", &amc, &sk, 120.0).unwrap();
    let figure = cpg_view::Figure::human("recording", &sk, &motion).unwrap();
    let mut scene = cpg_view::Scene::new("marked", 120.0, vec![figure]).unwrap();
    scene.marks =
        vec![cpg_view::Mark { time_s: 1.0, label: "walk".into() }, cpg_view::Mark { time_s: 2.0, label: "run".into() }];
    let html = dir.path().join("marked.html");
    std::fs::write(&html, scene.to_html()).unwrap();

    let mut b = Browser::start();
    b.open(&html);
    assert_eq!(b.eval("document.querySelectorAll('#ticks option').length"), json!(2));
    let labels = b.eval("Array.from(document.querySelectorAll('#marks button')).map(x => x.textContent).join('|')");
    assert_eq!(labels, json!("walk at 1.0 s|run at 2.0 s"));
    // Before the first mark the clock names no state.
    b.click("#play");
    b.eval(
        "(() => { const s = document.getElementById('time'); s.value = 30; s.dispatchEvent(new Event('input')); })()",
    );
    assert_eq!(b.eval("document.getElementById('clock').textContent"), json!("0.25 s / 2.98 s"));
    let before = b.screenshot();
    b.click("#play");
    b.click("#marks button:nth-child(2)");
    assert_eq!(b.eval("cpgView.playing"), json!(false), "a jump pauses");
    assert_eq!(b.eval("cpgView.frame"), json!(240));
    assert_eq!(b.eval("document.getElementById('clock').textContent"), json!("2.00 s / 2.98 s · run"));
    assert!(b.screenshot().differ(&before, 0, before.w, 0, before.h) > 200, "the jump did not change the picture");
    b.key("ArrowLeft", "ArrowLeft", 37);
    assert_eq!(b.eval("document.getElementById('clock').textContent"), json!("1.99 s / 2.98 s · walk"));
}

/// At 1200 × 800 (a laptop's window, scrollbars shown) the three panels
/// stand in one row and play/pause and the time slider are in view without
/// scrolling; the robot's panel once wrapped to a second row and pushed
/// them below the fold.
#[test]
fn at_1200_by_800_the_panels_stand_in_one_row_and_the_controls_are_in_view() {
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("view.html");
    ok(&cpg(&[
        OsStr::new("view"),
        "-m".as_ref(),
        walk22().as_os_str(),
        "--seconds".as_ref(),
        "2".as_ref(),
        "-o".as_ref(),
        html.as_os_str(),
    ]));
    let mut b = Browser::start_with(&[]);
    b.open_at(&html, 1200, 800);
    let tops =
        b.eval("Array.from(document.querySelectorAll('figure')).map(f => Math.round(f.getBoundingClientRect().top))");
    let tops: Vec<i64> = tops.as_array().unwrap().iter().map(|v| v.as_i64().unwrap()).collect();
    assert_eq!(tops.len(), 3);
    assert!(tops.iter().all(|&t| t == tops[0]), "the panels are on one row: tops {tops:?}");
    let right = b
        .eval("Math.max(...Array.from(document.querySelectorAll('figure')).map(f => f.getBoundingClientRect().right))");
    let width = b.eval("document.documentElement.clientWidth");
    assert!(right.as_f64().unwrap() <= width.as_f64().unwrap(), "no panel beyond the window: {right} > {width}");
    for id in ["play", "time", "clock"] {
        let r = b.eval(&format!("(() => {{ const r = document.getElementById('{id}').getBoundingClientRect(); return [r.top, r.bottom]; }})()"));
        let (top, bottom) = (r[0].as_f64().unwrap(), r[1].as_f64().unwrap());
        assert!(top >= 0.0 && bottom <= 800.0, "#{id} is in view without scrolling: {top}..{bottom}");
    }
    // The click reaches it: it pauses.
    b.click("#play");
    assert_eq!(b.eval("cpgView.playing"), json!(false));
}
