//! Skeleton profiles: where a person's pelvis, hips, knees, ankles, feet,
//! shoulders, elbows and wrists are in a skeleton, whatever its bones are
//! called.
//!
//! A profile names each **joint by the bone that starts there**: in a BVH
//! file that is the joint's own name (`LeftUpLeg` is the hip, `LeftLeg` the
//! knee), in CMU's ASF the bone that hangs from the joint (`lfemur` starts at
//! the hip, `ltibia` at the knee). The bone's rotation channels are the
//! joint's (`lfemur.rx`, `LeftUpLeg.rx`: the hip's flexion), and its start is
//! the joint's position, which forward kinematics names after the bone that
//! ends there ([`Resolved`] holds both).
//!
//! Two profiles are built in, [`CMU_ASF`] and [`CMU_BVH`] (the common BVH
//! conversion of the CMU database); [`Profile::detect`] picks the one whose
//! bones a skeleton has. Any other skeleton takes a profile file:
//!
//! ```toml
//! name = "my lab's suits"
//! pelvis = "root"        # the skeleton's root (whatever the file calls it), or a bone starting there
//! chest = "Neck"         # the bone that starts where the neck and the shoulders meet the trunk
//!
//! [left]
//! hip = "LeftUpLeg"
//! knee = "LeftLeg"
//! ankle = "LeftFoot"
//! toes = "LeftToeBase"   # starts at the ball of the foot
//! shoulder = "LeftArm"
//! elbow = "LeftForeArm"
//! wrist = "LeftHand"
//!
//! [right]
//! # the same seven names
//! ```
//!
//! `pelvis` is `root` (the skeleton's root, as ASF and this crate's BVH
//! reader call it) or a bone; every other name must be a bone of the
//! skeleton, which [`Profile::resolve`] checks, naming what is missing and
//! the nearest bone names.

use std::path::Path;

use crate::Skeleton;
use crate::error::{Error, Result};

/// The most bytes read from a profile file.
pub const MAX_PROFILE_BYTES: u64 = 64 << 10;

/// The point forward kinematics gives the skeleton's root.
pub const ROOT_POINT: &str = "root";

/// One side's joints, each named by the bone that starts there.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Limbs {
    /// Where the thigh starts.
    pub hip: String,
    /// Where the shank starts.
    pub knee: String,
    /// Where the foot starts.
    pub ankle: String,
    /// The bone that starts at the ball of the foot.
    pub toes: String,
    /// Where the upper arm starts.
    pub shoulder: String,
    /// Where the forearm starts.
    pub elbow: String,
    /// Where the hand starts.
    pub wrist: String,
}

impl Limbs {
    /// Each joint with its key in a profile file.
    pub fn named(&self) -> [(&'static str, &str); 7] {
        [
            ("hip", &self.hip),
            ("knee", &self.knee),
            ("ankle", &self.ankle),
            ("toes", &self.toes),
            ("shoulder", &self.shoulder),
            ("elbow", &self.elbow),
            ("wrist", &self.wrist),
        ]
    }
}

/// Where a skeleton's body parts are (see the module).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Profile {
    /// What the profile is for (`cmu-asf`, `cmu-bvh`, or a file's `name`).
    pub name: String,
    /// The pelvis: the skeleton's root, or the bone that starts there.
    pub pelvis: String,
    /// The bone that starts at the top of the trunk, where the neck and shoulders meet it.
    pub chest: String,
    /// The left side.
    pub left: Limbs,
    /// The right side.
    pub right: Limbs,
}

fn limbs(n: [&str; 7]) -> Limbs {
    let [hip, knee, ankle, toes, shoulder, elbow, wrist] = n.map(str::to_owned);
    Limbs { hip, knee, ankle, toes, shoulder, elbow, wrist }
}

/// The CMU database's ASF skeletons.
pub fn cmu_asf() -> Profile {
    Profile {
        name: CMU_ASF.into(),
        pelvis: ROOT_POINT.into(),
        chest: "lowerneck".into(),
        left: limbs(["lfemur", "ltibia", "lfoot", "ltoes", "lhumerus", "lradius", "lwrist"]),
        right: limbs(["rfemur", "rtibia", "rfoot", "rtoes", "rhumerus", "rradius", "rwrist"]),
    }
}

/// The common BVH conversion of the CMU database (`Hips`, `LeftUpLeg`, …).
pub fn cmu_bvh() -> Profile {
    Profile {
        name: CMU_BVH.into(),
        pelvis: ROOT_POINT.into(),
        chest: "Neck".into(),
        left: limbs(["LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "LeftArm", "LeftForeArm", "LeftHand"]),
        right: limbs(["RightUpLeg", "RightLeg", "RightFoot", "RightToeBase", "RightArm", "RightForeArm", "RightHand"]),
    }
}

/// The built-in profile of CMU's ASF skeletons.
pub const CMU_ASF: &str = "cmu-asf";
/// The built-in profile of CMU's BVH conversion.
pub const CMU_BVH: &str = "cmu-bvh";

/// The built-in profiles, by name.
pub fn builtin(name: &str) -> Option<Profile> {
    match name {
        CMU_ASF => Some(cmu_asf()),
        CMU_BVH => Some(cmu_bvh()),
        _ => None,
    }
}

/// A profile resolved on one skeleton: every joint as the point forward
/// kinematics names (the end of the bone before it) and as the bone whose
/// rotation channels are the joint's.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Resolved {
    /// The profile's name.
    pub profile: String,
    /// The pelvis's point.
    pub pelvis: String,
    /// The top of the trunk's point.
    pub chest: String,
    /// Left then right: each side's joints as points.
    pub sides: [SidePoints; 2],
}

/// One side's joints as points of forward kinematics, and the bones that rotate there.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SidePoints {
    /// Hip, knee, ankle and ball of the foot (the points).
    pub hip: String,
    /// The knee's point.
    pub knee: String,
    /// The ankle's point.
    pub ankle: String,
    /// The ball of the foot's point (where the toes start).
    pub ball: String,
    /// The shoulder's point.
    pub shoulder: String,
    /// The elbow's point.
    pub elbow: String,
    /// The wrist's point.
    pub wrist: String,
    /// The bones that rotate at the hip, knee and ankle (their channels are the joints').
    pub hip_bone: String,
    /// The knee's bone.
    pub knee_bone: String,
    /// The ankle's bone.
    pub ankle_bone: String,
    /// The shoulder's bone.
    pub shoulder_bone: String,
    /// The elbow's bone.
    pub elbow_bone: String,
}

impl Profile {
    /// The built-in profile whose bones `sk` has (CMU ASF first), or `None`.
    pub fn detect(sk: &Skeleton) -> Option<Profile> {
        [cmu_asf(), cmu_bvh()].into_iter().find(|p| p.resolve(sk).is_ok())
    }

    /// The profile for `sk`: the one given, or the built-in one it fits; an
    /// error naming what is missing when none does.
    pub fn for_skeleton(sk: &Skeleton, given: Option<&Profile>) -> Result<Resolved> {
        match given {
            Some(p) => p.resolve(sk),
            None => match Profile::detect(sk) {
                Some(p) => p.resolve(sk),
                None => {
                    let why = |p: Profile| match p.resolve(sk) {
                        Err(Error::InvalidArgument(m)) => m,
                        Err(e) => e.to_string(),
                        Ok(_) => String::new(),
                    };
                    Err(Error::InvalidArgument(format!(
                        "skeleton '{}' fits neither built-in profile ({}; {}); give a profile file naming its hips, knees, ankles, toes, shoulders, elbows and wrists (docs/skeletons.md)",
                        sk.name,
                        why(cmu_asf()),
                        why(cmu_bvh()),
                    )))
                }
            },
        }
    }

    /// Every name checked against `sk`'s bones and turned into points.
    pub fn resolve(&self, sk: &Skeleton) -> Result<Resolved> {
        let bone_names = || sk.bones.iter().map(|b| b.name.as_str());
        let missing = |key: &str, name: &str| {
            Error::InvalidArgument(format!(
                "profile '{}': {key} = '{name}' is not a bone of skeleton '{}'{}",
                self.name,
                sk.name,
                cpg_io::did_you_mean(name, bone_names())
            ))
        };
        // A joint's point: the end of the bone before the one that starts there.
        let start_of = |key: &str, name: &str| -> Result<String> {
            if name == ROOT_POINT {
                return Ok(ROOT_POINT.into());
            }
            let k = sk.bone_index(name).ok_or_else(|| missing(key, name))?;
            Ok(sk.bones[k].parent.map_or(ROOT_POINT.to_owned(), |p| sk.bones[p].name.clone()))
        };
        let bone = |key: &str, name: &str| -> Result<String> {
            sk.bone_index(name).map(|_| name.to_owned()).ok_or_else(|| missing(key, name))
        };
        let side = |l: &Limbs, which: &str| -> Result<SidePoints> {
            let key = |k: &str| format!("{which}.{k}");
            Ok(SidePoints {
                hip: start_of(&key("hip"), &l.hip)?,
                knee: start_of(&key("knee"), &l.knee)?,
                ankle: start_of(&key("ankle"), &l.ankle)?,
                ball: start_of(&key("toes"), &l.toes)?,
                shoulder: start_of(&key("shoulder"), &l.shoulder)?,
                elbow: start_of(&key("elbow"), &l.elbow)?,
                wrist: start_of(&key("wrist"), &l.wrist)?,
                hip_bone: bone(&key("hip"), &l.hip)?,
                knee_bone: bone(&key("knee"), &l.knee)?,
                ankle_bone: bone(&key("ankle"), &l.ankle)?,
                shoulder_bone: bone(&key("shoulder"), &l.shoulder)?,
                elbow_bone: bone(&key("elbow"), &l.elbow)?,
            })
        };
        Ok(Resolved {
            profile: self.name.clone(),
            pelvis: start_of("pelvis", &self.pelvis)?,
            chest: start_of("chest", &self.chest)?,
            sides: [side(&self.left, "left")?, side(&self.right, "right")?],
        })
    }

    /// Reads a profile file (see the module for its format).
    pub fn from_file(path: impl AsRef<Path>) -> Result<Profile> {
        let path = path.as_ref();
        let bytes = crate::read_bounded(path, MAX_PROFILE_BYTES)?;
        let text = std::str::from_utf8(&bytes).map_err(|e| {
            Error::InvalidArgument(format!("{}: not UTF-8 text (byte {})", path.display(), e.valid_up_to()))
        })?;
        Profile::parse(&crate::file_label(path), text)
    }

    /// Parses a profile's text; `label` names it in errors.
    pub fn parse(label: &str, text: &str) -> Result<Profile> {
        let mut top: Vec<(&str, Option<String>)> = vec![("name", None), ("pelvis", None), ("chest", None)];
        let mut sides: [Vec<(&str, Option<String>)>; 2] = std::array::from_fn(|_| {
            ["hip", "knee", "ankle", "toes", "shoulder", "elbow", "wrist"].map(|k| (k, None)).to_vec()
        });
        let mut section: Option<usize> = None;
        let fail = |line: usize, what: String| Error::InvalidArgument(format!("{label}, line {line}: {what}"));
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let l = strip_comment(raw).trim();
            if l.is_empty() {
                continue;
            }
            if let Some(rest) = l.strip_prefix('[') {
                let name = rest.strip_suffix(']').map(str::trim);
                section = match name {
                    Some("left") => Some(0),
                    Some("right") => Some(1),
                    _ => return Err(fail(line, format!("'{l}': expected [left] or [right]"))),
                };
                continue;
            }
            let Some((key, value)) = l.split_once('=') else {
                return Err(fail(line, format!("'{l}': expected key = \"bone name\"")));
            };
            let (key, value) = (key.trim(), value.trim());
            let value = value
                .strip_prefix('"')
                .and_then(|v| v.strip_suffix('"'))
                .filter(|v| !v.is_empty() && v.len() <= 200 && !v.contains('"'))
                .ok_or_else(|| fail(line, format!("{key}: expected a quoted bone name of 1 to 200 characters")))?;
            let table = match section {
                None => &mut top,
                Some(s) => &mut sides[s],
            };
            let where_ = section.map_or("at the top", |s| if s == 0 { "in [left]" } else { "in [right]" });
            let keys: Vec<&str> = table.iter().map(|(k, _)| *k).collect();
            let Some(slot) = table.iter_mut().find(|(k, _)| *k == key) else {
                return Err(fail(
                    line,
                    format!(
                        "unknown key '{key}' {where_}{}; expected one of {}",
                        cpg_io::did_you_mean(key, keys.iter().copied()),
                        keys.join(", ")
                    ),
                ));
            };
            if slot.1.is_some() {
                return Err(fail(line, format!("{key} is given twice {where_}")));
            }
            slot.1 = Some(value.to_owned());
        }
        let take = |t: &[(&str, Option<String>)], k: &str, where_: &str| -> Result<String> {
            t.iter().find(|(x, _)| *x == k).and_then(|(_, v)| v.clone()).ok_or_else(|| {
                Error::InvalidArgument(format!(
                    "{label}: {k} is missing {where_} (a profile names {})",
                    "pelvis, chest and each side's hip, knee, ankle, toes, shoulder, elbow and wrist"
                ))
            })
        };
        let side = |s: usize, where_: &str| -> Result<Limbs> {
            let t = &sides[s];
            Ok(Limbs {
                hip: take(t, "hip", where_)?,
                knee: take(t, "knee", where_)?,
                ankle: take(t, "ankle", where_)?,
                toes: take(t, "toes", where_)?,
                shoulder: take(t, "shoulder", where_)?,
                elbow: take(t, "elbow", where_)?,
                wrist: take(t, "wrist", where_)?,
            })
        };
        Ok(Profile {
            name: take(&top, "name", "at the top").unwrap_or_else(|_| label.to_owned()),
            pelvis: take(&top, "pelvis", "at the top")?,
            chest: take(&top, "chest", "at the top")?,
            left: side(0, "in [left]")?,
            right: side(1, "in [right]")?,
        })
    }
}

/// `line` without a `#` comment outside quotes.
fn strip_comment(line: &str) -> &str {
    let mut quoted = false;
    for (i, c) in line.char_indices() {
        match c {
            '"' => quoted = !quoted,
            '#' if !quoted => return &line[..i],
            _ => {}
        }
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_profile_file_reads_back_as_the_built_in_it_spells() {
        let text = "name = \"cmu-bvh\"  # the CMU conversion\npelvis = \"root\"\nchest = \"Neck\"\n\n[left]\nhip = \"LeftUpLeg\"\nknee = \"LeftLeg\"\nankle = \"LeftFoot\"\ntoes = \"LeftToeBase\"\nshoulder = \"LeftArm\"\nelbow = \"LeftForeArm\"\nwrist = \"LeftHand\"\n[right]\nhip = \"RightUpLeg\"\nknee = \"RightLeg\"\nankle = \"RightFoot\"\ntoes = \"RightToeBase\"\nshoulder = \"RightArm\"\nelbow = \"RightForeArm\"\nwrist = \"RightHand\"\n";
        assert_eq!(Profile::parse("p.toml", text).unwrap(), cmu_bvh());
    }

    #[test]
    fn a_bad_profile_file_names_its_line_and_what_was_expected() {
        let e = Profile::parse("p.toml", "pelvis = \"root\"\nchset = \"Neck\"\n").unwrap_err().to_string();
        assert!(e.contains("p.toml, line 2") && e.contains("unknown key 'chset'") && e.contains("chest"), "{e}");
        let e = Profile::parse("p.toml", "[arms]\n").unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("[left] or [right]"), "{e}");
        let e = Profile::parse("p.toml", "pelvis = root\n").unwrap_err().to_string();
        assert!(e.contains("quoted bone name"), "{e}");
        let e = Profile::parse("p.toml", "pelvis = \"root\"\nchest = \"Neck\"\n[left]\nhip = \"a\"\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("knee is missing in [left]"), "{e}");
        let e = Profile::parse("p.toml", "pelvis = \"a\"\npelvis = \"b\"\n").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("twice"), "{e}");
    }
}
