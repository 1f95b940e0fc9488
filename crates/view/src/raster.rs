//! The GIF: every figure drawn into its own panel by a small rasteriser
//! (thick segments as capsules, labels in the crate's bitmap font), with the
//! projection the HTML viewer uses.

use crate::{Camera, Error, Figure, Result, Scene, Side, font};

/// How the GIF is drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct GifOptions {
    /// Width of one figure's panel, pixels (64 to 1024).
    pub panel_width_px: u16,
    /// Height of a panel, pixels (64 to 1024).
    pub panel_height_px: u16,
    /// Frames per second asked for; the GIF stores delays in hundredths of a
    /// second, so the delay is rounded and the frames are sampled at exactly
    /// that delay: the animation plays in real time.
    pub fps: f64,
    /// Seconds shown from the start of the scene [default: all of it, at most
    /// [`MAX_GIF_FRAMES`] frames].
    pub seconds: Option<f64>,
    /// The view [default: the scene's].
    pub camera: Option<Camera>,
}

impl Default for GifOptions {
    fn default() -> GifOptions {
        GifOptions { panel_width_px: 320, panel_height_px: 400, fps: 25.0, seconds: None, camera: None }
    }
}

/// The most frames one GIF holds.
pub const MAX_GIF_FRAMES: usize = 3000;

const PALETTE: [[u8; 3]; 8] = [
    [255, 255, 255], // 0 background
    [222, 222, 222], // 1 floor grid
    [60, 60, 60],    // 2 centre segments
    [31, 111, 209],  // 3 left limbs
    [214, 64, 48],   // 4 right limbs
    [0, 0, 0],       // 5 text
    [170, 170, 170], // 6 panel border
    [120, 120, 120], // 7 spare
];

fn ink(side: Side) -> u8 {
    match side {
        Side::Center => 2,
        Side::Left => 3,
        Side::Right => 4,
    }
}

/// A step of 1, 2 or 5 × 10^k at or above `x`.
pub(crate) fn nice_step(x: f64) -> f64 {
    let x = x.max(1e-9);
    let p = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * p).find(|s| *s >= x * 0.999).unwrap_or(10.0 * p)
}

/// An orthographic camera around a focus point.
struct View {
    cos_yaw: f64,
    sin_yaw: f64,
    cos_pitch: f64,
    sin_pitch: f64,
    scale: f64,
    centre: (f64, f64),
    focus: [f64; 3],
}

impl View {
    fn new(cam: Camera, fig: &Figure, frame: &[[f32; 3]], w: f64, h: f64) -> View {
        let height = f64::from(fig.height_mm()).max(1.0);
        let (sy, cy) = cam.yaw_deg.to_radians().sin_cos();
        let (sp, cp) = cam.pitch_deg.to_radians().sin_cos();
        let root = frame.first().copied().unwrap_or([0.0; 3]);
        View {
            cos_yaw: cy,
            sin_yaw: sy,
            cos_pitch: cp,
            sin_pitch: sp,
            scale: 0.72 * h / height,
            centre: (w / 2.0, h * 0.52),
            focus: [f64::from(root[0]), height / 2.0, f64::from(root[2])],
        }
    }

    /// Screen x, screen y (down) and depth (larger is nearer the camera).
    fn project(&self, p: [f64; 3]) -> (f64, f64, f64) {
        let (dx, dy, dz) = (p[0] - self.focus[0], p[1] - self.focus[1], p[2] - self.focus[2]);
        let right = dx * self.cos_yaw - dz * self.sin_yaw;
        let toward = dx * self.sin_yaw + dz * self.cos_yaw;
        let up = dy * self.cos_pitch - toward * self.sin_pitch;
        let depth = toward * self.cos_pitch + dy * self.sin_pitch;
        (self.centre.0 + right * self.scale, self.centre.1 - up * self.scale, depth)
    }
}

/// An indexed image.
struct Canvas {
    w: usize,
    h: usize,
    px: Vec<u8>,
}

impl Canvas {
    fn set(&mut self, x: i64, y: i64, c: u8) {
        if x >= 0 && y >= 0 && (x as usize) < self.w && (y as usize) < self.h {
            self.px[y as usize * self.w + x as usize] = c;
        }
    }

    /// Every pixel within `r` of the segment a–b, clipped to the x range `[x_lo, x_hi)`.
    fn capsule(&mut self, a: (f64, f64), b: (f64, f64), r: f64, c: u8, x_lo: i64, x_hi: i64) {
        let (x0, x1) = ((a.0.min(b.0) - r).floor() as i64, (a.0.max(b.0) + r).ceil() as i64);
        let (y0, y1) = ((a.1.min(b.1) - r).floor() as i64, (a.1.max(b.1) + r).ceil() as i64);
        let (vx, vy) = (b.0 - a.0, b.1 - a.1);
        let len2 = vx * vx + vy * vy;
        for y in y0.max(0)..=y1.min(self.h as i64 - 1) {
            for x in x0.max(x_lo)..=x1.min(x_hi - 1) {
                let (px, py) = (x as f64 + 0.5 - a.0, y as f64 + 0.5 - a.1);
                let t = if len2 > 0.0 { ((px * vx + py * vy) / len2).clamp(0.0, 1.0) } else { 0.0 };
                let (ex, ey) = (px - t * vx, py - t * vy);
                if ex * ex + ey * ey <= r * r {
                    self.set(x, y, c);
                }
            }
        }
    }

    fn text(&mut self, s: &str, x: i64, y: i64, scale: i64, c: u8) {
        let mut pts = Vec::new();
        font::draw(s, x, y, scale, |px, py| pts.push((px, py)));
        for (px, py) in pts {
            self.set(px, py, c);
        }
    }
}

/// Draws one frame of one figure into the panel starting at `x_off`.
fn panel(cv: &mut Canvas, fig: &Figure, frame_idx: usize, cam: Camera, x_off: usize, w: usize, h: usize) {
    let n = fig.names.len();
    let pts = &fig.points_mm[frame_idx * n..(frame_idx + 1) * n];
    let v = View::new(cam, fig, pts, w as f64, h as f64);
    let (lo, hi) = (x_off as i64, (x_off + w) as i64);
    let shift = |p: (f64, f64, f64)| (p.0 + x_off as f64, p.1);
    // The floor: a grid of lines every `step` mm around the focus, fixed in the world.
    let height = f64::from(fig.height_mm()).max(1.0);
    let step = nice_step(height / 4.0);
    let reach = 2.5 * height;
    let (fx, fz) = (v.focus[0], v.focus[2]);
    let k0 = ((fx - reach) / step).ceil() as i64;
    let k1 = ((fx + reach) / step).floor() as i64;
    for k in k0..=k1 {
        let x = k as f64 * step;
        let a = shift(v.project([x, 0.0, fz - reach]));
        let b = shift(v.project([x, 0.0, fz + reach]));
        cv.capsule(a, b, 0.6, 1, lo, hi);
    }
    let k0 = ((fz - reach) / step).ceil() as i64;
    let k1 = ((fz + reach) / step).floor() as i64;
    for k in k0..=k1 {
        let z = k as f64 * step;
        let a = shift(v.project([fx - reach, 0.0, z]));
        let b = shift(v.project([fx + reach, 0.0, z]));
        cv.capsule(a, b, 0.6, 1, lo, hi);
    }
    // Segments, the farthest first.
    let proj: Vec<(f64, f64, f64)> = pts.iter().map(|p| v.project(p.map(f64::from))).collect();
    let mut order: Vec<usize> = (0..fig.segments.len()).collect();
    order.sort_by(|&a, &b| {
        let d = |s: usize| proj[fig.segments[s].0].2 + proj[fig.segments[s].1].2;
        d(a).total_cmp(&d(b))
    });
    let r = (h as f64 / 130.0).max(1.2);
    for s in order {
        let (a, b, side) = fig.segments[s];
        cv.capsule(shift(proj[a]), shift(proj[b]), r, ink(side), lo, hi);
    }
    if let Some(k) = fig.names.iter().position(|n| n == "head") {
        let p = shift(proj[k]);
        cv.capsule(p, p, 2.6 * r, 2, lo, hi);
    }
    cv.text(&fig.label, x_off as i64 + 8, 8, 2, 5);
}

/// The scene as an animated GIF.
pub(crate) fn gif(scene: &Scene, o: &GifOptions) -> Result<Vec<u8>> {
    let bad = |m: String| Err(Error::Input(m));
    for (name, v) in [("panel width", o.panel_width_px), ("panel height", o.panel_height_px)] {
        if !(64..=1024).contains(&v) {
            return bad(format!("{name} {v} px: expected 64 to 1024"));
        }
    }
    if !(o.fps.is_finite() && (1.0..=100.0).contains(&o.fps)) {
        return bad(format!("{} frames per second: expected 1 to 100", o.fps));
    }
    let delay_cs = (100.0 / o.fps).round().max(1.0) as u16;
    let dt = f64::from(delay_cs) / 100.0;
    let scene_s = scene.n_frames() as f64 / scene.rate_hz;
    let seconds = match o.seconds {
        Some(s) if !(s.is_finite() && s > 0.0) => return bad(format!("{s} seconds: expected a positive duration")),
        Some(s) => s.min(scene_s),
        None => scene_s,
    };
    let n_gif = ((seconds / dt).floor() as usize).max(1);
    if n_gif > MAX_GIF_FRAMES {
        return bad(format!(
            "{n_gif} GIF frames ({seconds:.1} s at {:.0} per second): at most {MAX_GIF_FRAMES}; show fewer seconds",
            1.0 / dt
        ));
    }
    let cam = o.camera.unwrap_or(scene.camera);
    let (pw, ph) = (usize::from(o.panel_width_px), usize::from(o.panel_height_px));
    let w = pw * scene.figures.len();
    let Ok(w16) = u16::try_from(w) else {
        return bad(format!("{} panels of {pw} px are wider than a GIF can be", scene.figures.len()));
    };
    let palette: Vec<u8> = PALETTE.iter().flatten().copied().collect();
    let mut out = Vec::new();
    {
        let mut enc =
            gif::Encoder::new(&mut out, w16, o.panel_height_px, &palette).map_err(|e| Error::Gif(e.to_string()))?;
        enc.set_repeat(gif::Repeat::Infinite).map_err(|e| Error::Gif(e.to_string()))?;
        let mut cv = Canvas { w, h: ph, px: vec![0; w * ph] };
        for g in 0..n_gif {
            let t = g as f64 * dt;
            let f = ((t * scene.rate_hz).round() as usize).min(scene.n_frames() - 1);
            cv.px.fill(0);
            for (k, fig) in scene.figures.iter().enumerate() {
                panel(&mut cv, fig, f, cam, k * pw, pw, ph);
                if k > 0 {
                    for y in 0..ph as i64 {
                        cv.set((k * pw) as i64, y, 6);
                    }
                }
            }
            cv.text(&format!("T = {t:.2} S"), 8, ph as i64 - 22, 2, 5);
            let mut frame = gif::Frame::from_indexed_pixels(w16, o.panel_height_px, cv.px.clone(), None);
            frame.delay = delay_cs;
            enc.write_frame(&frame).map_err(|e| Error::Gif(e.to_string()))?;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    #[test]
    fn nice_steps_are_one_two_or_five_times_a_power_of_ten() {
        assert_eq!(super::nice_step(420.0), 500.0);
        assert_eq!(super::nice_step(130.0), 200.0);
        assert_eq!(super::nice_step(100.0), 100.0);
        assert_eq!(super::nice_step(0.7), 1.0);
    }
}
