//! Motions: frames × named channels at an explicit sample rate.

use std::fmt;
use std::path::Path;

use crate::error::{Error, Result};
use crate::{Dof, Skeleton};

/// One channel: a bone (or `root`) and one of its DOFs. Written `lfemur.rx`.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Channel {
    /// Bone name, or `root`.
    pub bone: String,
    /// Degree of freedom.
    pub dof: Dof,
}

impl Channel {
    /// Parses `bone.dof`.
    pub fn parse(name: &str) -> Option<Channel> {
        let (bone, dof) = name.rsplit_once('.')?;
        if bone.is_empty() {
            return None;
        }
        Some(Channel { bone: bone.to_owned(), dof: Dof::parse(dof)? })
    }
}

impl fmt::Display for Channel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}", self.bone, self.dof.as_str())
    }
}

/// A motion: `n_frames` frames of `channels.len()` values, stored frame-major.
///
/// Rotation channels are in degrees; translation channels in skeleton units.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    channels: Vec<Channel>,
    values: Vec<f64>,
    sample_rate_hz: f64,
}

impl Motion {
    /// Builds a motion from frame-major values.
    ///
    /// Fails when the value count is not a multiple of the channel count, a
    /// value is not finite, or the rate is not a positive finite number.
    pub fn new(channels: Vec<Channel>, values: Vec<f64>, sample_rate_hz: f64) -> Result<Motion> {
        if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
            return Err(Error::InvalidArgument(format!(
                "sample rate must be a positive number of Hz, got {sample_rate_hz}"
            )));
        }
        if channels.is_empty() {
            return Err(Error::InvalidArgument("a motion needs at least one channel".into()));
        }
        if !values.len().is_multiple_of(channels.len()) {
            return Err(Error::InvalidArgument(format!(
                "{} values do not divide into frames of {} channels",
                values.len(),
                channels.len()
            )));
        }
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(Error::InvalidArgument(format!(
                "value of channel '{}' in frame {} is not finite",
                channels[k % channels.len()],
                k / channels.len()
            )));
        }
        for (k, c) in channels.iter().enumerate() {
            if channels[..k].contains(c) {
                return Err(Error::InvalidArgument(format!("channel '{c}' appears twice")));
            }
        }
        Ok(Motion { channels, values, sample_rate_hz })
    }

    /// Reads an AMC file against a skeleton.
    pub fn from_amc_file(path: impl AsRef<Path>, skeleton: &Skeleton, sample_rate_hz: f64) -> Result<Motion> {
        let path = path.as_ref();
        let bytes = crate::read_bounded(path, crate::MAX_INPUT_BYTES)?;
        crate::parse_amc(&crate::file_label(path), &bytes, skeleton, sample_rate_hz)
    }

    /// The channels, in column order.
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// Channel names (`lfemur.rx`), in column order.
    pub fn channel_names(&self) -> Vec<String> {
        self.channels.iter().map(|c| c.to_string()).collect()
    }

    /// Number of frames.
    pub fn n_frames(&self) -> usize {
        self.values.len() / self.channels.len()
    }

    /// Number of channels.
    pub fn n_channels(&self) -> usize {
        self.channels.len()
    }

    /// Sample rate in Hz.
    pub fn sample_rate_hz(&self) -> f64 {
        self.sample_rate_hz
    }

    /// Duration in seconds (frames / rate).
    pub fn duration_s(&self) -> f64 {
        self.n_frames() as f64 / self.sample_rate_hz
    }

    /// All values, frame-major.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// One frame.
    ///
    /// # Panics
    /// When `frame_idx >= n_frames()`.
    #[track_caller]
    pub fn frame(&self, frame_idx: usize) -> &[f64] {
        let n = self.channels.len();
        &self.values[frame_idx * n..(frame_idx + 1) * n]
    }

    /// Column index of a channel by name.
    pub fn channel_index(&self, name: &str) -> Result<usize> {
        self.channels
            .iter()
            .position(|c| c.to_string() == name)
            .ok_or_else(|| Error::UnknownChannel { name: name.to_owned(), valid: self.channel_names() })
    }

    /// One channel as a time series.
    pub fn column(&self, name: &str) -> Result<Vec<f64>> {
        let k = self.channel_index(name)?;
        Ok(self.column_at(k))
    }

    /// One channel by column index.
    ///
    /// # Panics
    /// When `idx >= n_channels()`.
    #[track_caller]
    pub fn column_at(&self, idx: usize) -> Vec<f64> {
        assert!(idx < self.channels.len(), "channel index {idx} out of range");
        self.values.iter().skip(idx).step_by(self.channels.len()).copied().collect()
    }

    /// A motion with only the named channels, in the order given.
    pub fn select(&self, names: &[&str]) -> Result<Motion> {
        let idx: Vec<usize> = names.iter().map(|n| self.channel_index(n)).collect::<Result<_>>()?;
        let mut values = Vec::with_capacity(idx.len() * self.n_frames());
        for f in 0..self.n_frames() {
            let row = self.frame(f);
            values.extend(idx.iter().map(|&k| row[k]));
        }
        Motion::new(idx.iter().map(|&k| self.channels[k].clone()).collect(), values, self.sample_rate_hz)
    }

    /// Frames `start..end`.
    pub fn slice(&self, start: usize, end: usize) -> Result<Motion> {
        if start >= end || end > self.n_frames() {
            return Err(Error::InvalidArgument(format!(
                "frame range {start}..{end} is empty or outside 0..{}",
                self.n_frames()
            )));
        }
        let n = self.channels.len();
        Ok(Motion {
            channels: self.channels.clone(),
            values: self.values[start * n..end * n].to_vec(),
            sample_rate_hz: self.sample_rate_hz,
        })
    }

    /// This motion followed by `other` (same channels and rate required).
    pub fn concat(&self, other: &Motion) -> Result<Motion> {
        if self.channels != other.channels {
            return Err(Error::Mismatch("channels differ".into()));
        }
        if self.sample_rate_hz != other.sample_rate_hz {
            return Err(Error::Mismatch(format!(
                "sample rates differ ({} Hz and {} Hz)",
                self.sample_rate_hz, other.sample_rate_hz
            )));
        }
        let mut values = self.values.clone();
        values.extend_from_slice(&other.values);
        Ok(Motion { channels: self.channels.clone(), values, sample_rate_hz: self.sample_rate_hz })
    }

    /// This motion repeated `times` times.
    pub fn repeat(&self, times: usize) -> Result<Motion> {
        if times == 0 {
            return Err(Error::InvalidArgument("repeat count must be at least 1".into()));
        }
        Ok(Motion {
            channels: self.channels.clone(),
            values: self.values.repeat(times),
            sample_rate_hz: self.sample_rate_hz,
        })
    }

    /// Resamples with a time-varying rate factor.
    ///
    /// Output frame `k` is the motion read at position `p_k` (in input frames,
    /// linear interpolation), with `p_0 = start_frame` and `p_{k+1} = p_k + rate[k]`.
    /// A rate of 2 plays the motion twice as fast. With `periodic`, the motion
    /// is treated as a loop (the last frame is followed by the first); without,
    /// reading past the last frame is an error. The output has `rate.len()` frames
    /// at the same sample rate.
    pub fn resample_by_rate(&self, rate: &[f64], start_frame: f64, periodic: bool) -> Result<Motion> {
        let n_in = self.n_frames();
        let n = self.channels.len();
        if let Some(k) = rate.iter().position(|r| !(r.is_finite() && *r > 0.0)) {
            return Err(Error::InvalidArgument(format!("rate[{k}] = {} must be positive and finite", rate[k])));
        }
        if rate.is_empty() {
            return Err(Error::InvalidArgument("rate must have at least one value".into()));
        }
        if !(start_frame.is_finite() && start_frame >= 0.0) {
            return Err(Error::InvalidArgument(format!("start frame {start_frame} must be >= 0")));
        }
        let mut values = Vec::with_capacity(rate.len() * n);
        let mut p = start_frame;
        let span = n_in as f64;
        for (k, r) in rate.iter().enumerate() {
            let pos = if periodic { p.rem_euclid(span) } else { p };
            if !periodic && pos > (n_in - 1) as f64 {
                return Err(Error::InvalidArgument(format!(
                    "output frame {k} reads input position {pos:.2}, past the last frame {}",
                    n_in - 1
                )));
            }
            let i0 = (pos.floor() as usize).min(n_in - 1);
            let i1 = if periodic { (i0 + 1) % n_in } else { (i0 + 1).min(n_in - 1) };
            let t = pos - i0 as f64;
            let (a, b) = (self.frame(i0), self.frame(i1));
            values.extend(a.iter().zip(b).map(|(x, y)| x + t * (y - x)));
            p += r;
        }
        Ok(Motion { channels: self.channels.clone(), values, sample_rate_hz: self.sample_rate_hz })
    }
}

/// Per-channel z-score normalisation `(x − mean) / std`, invertible.
#[derive(Debug, Clone, PartialEq)]
pub struct ZScore {
    /// Channel names the statistics belong to.
    pub channels: Vec<String>,
    /// Mean per channel.
    pub mean: Vec<f64>,
    /// Population standard deviation per channel.
    pub std: Vec<f64>,
}

impl ZScore {
    /// Fits mean and standard deviation of every channel.
    ///
    /// Fails on a constant channel, which cannot be normalised.
    pub fn fit(m: &Motion) -> Result<ZScore> {
        let (z, still) = ZScore::fit_holding_still(m);
        match still.first() {
            Some(&k) => Err(Error::ConstantChannel(m.channels()[k].to_string())),
            None => Ok(z),
        }
    }

    /// Fits mean and standard deviation of every channel; a channel that
    /// never moves (a standard deviation within 1e-12 of its size) keeps its
    /// own units (standard deviation 1: it normalises to 0) and is listed.
    pub fn fit_holding_still(m: &Motion) -> (ZScore, Vec<usize>) {
        let n = m.n_channels();
        let t = m.n_frames() as f64;
        let mut mean = vec![0.0; n];
        for f in 0..m.n_frames() {
            for (s, v) in mean.iter_mut().zip(m.frame(f)) {
                *s += v;
            }
        }
        mean.iter_mut().for_each(|s| *s /= t);
        let mut var = vec![0.0; n];
        for f in 0..m.n_frames() {
            for ((s, v), mu) in var.iter_mut().zip(m.frame(f)).zip(&mean) {
                *s += (v - mu) * (v - mu);
            }
        }
        let mut std: Vec<f64> = var.iter().map(|v| (v / t).sqrt()).collect();
        let mut still = Vec::new();
        for (k, s) in std.iter_mut().enumerate() {
            if *s <= 1e-12 * (1.0 + mean[k].abs()) {
                *s = 1.0;
                still.push(k);
            }
        }
        (ZScore { channels: m.channel_names(), mean, std }, still)
    }

    fn check(&self, m: &Motion) -> Result<()> {
        if m.channel_names() != self.channels {
            return Err(Error::Mismatch(format!(
                "normalisation is for channels [{}], motion has [{}]",
                self.channels.join(", "),
                m.channel_names().join(", ")
            )));
        }
        Ok(())
    }

    /// Normalises a motion with the fitted statistics.
    pub fn apply(&self, m: &Motion) -> Result<Motion> {
        self.check(m)?;
        let n = self.mean.len();
        let values = m.values().iter().enumerate().map(|(k, v)| (v - self.mean[k % n]) / self.std[k % n]).collect();
        Motion::new(m.channels().to_vec(), values, m.sample_rate_hz())
    }

    /// Maps normalised values back to the original units.
    pub fn invert(&self, m: &Motion) -> Result<Motion> {
        self.check(m)?;
        let n = self.mean.len();
        let values = m.values().iter().enumerate().map(|(k, v)| v * self.std[k % n] + self.mean[k % n]).collect();
        Motion::new(m.channels().to_vec(), values, m.sample_rate_hz())
    }
}
