//! Channel names, globs and groups.
//!
//! A channel is `bone.dof` (`lfemur.rx`). A configuration may also name a
//! glob (`lfemur.*`, `*.rx`) or a group:
//!
//! | group | channels |
//! |---|---|
//! | `legs` | the 12 leg channels of the HOAP-2 map, left then right: femur ry, rz, rx; tibia rx; foot rx, rz |
//! | `arms` | the 10 arm channels of the HOAP-2 map: humerus rx, rz, ry; radius rx; wrist ry, left then right |
//! | `hoap2` | `legs` then `arms`: the 22 channels of `assets/hoap2/cmu35_to_hoap2.tsv`, in its order |
//!
//! Globs and groups expand against the skeleton's degrees of freedom; a
//! channel named twice (directly or through a group) is an error.

use cpg_mocap::Skeleton;

/// The leg channels of the HOAP-2 map.
pub const LEGS: [&str; 12] = [
    "lfemur.ry",
    "lfemur.rz",
    "lfemur.rx",
    "ltibia.rx",
    "lfoot.rx",
    "lfoot.rz",
    "rfemur.ry",
    "rfemur.rz",
    "rfemur.rx",
    "rtibia.rx",
    "rfoot.rx",
    "rfoot.rz",
];

/// The arm channels of the HOAP-2 map.
pub const ARMS: [&str; 10] = [
    "lhumerus.rx",
    "lhumerus.rz",
    "lhumerus.ry",
    "lradius.rx",
    "lwrist.ry",
    "rhumerus.rx",
    "rhumerus.rz",
    "rhumerus.ry",
    "rradius.rx",
    "rwrist.ry",
];

/// The channels of a group, or `None` for a name that is not a group.
pub fn group(name: &str) -> Option<Vec<&'static str>> {
    match name {
        "legs" => Some(LEGS.to_vec()),
        "arms" => Some(ARMS.to_vec()),
        "hoap2" => Some(LEGS.iter().chain(&ARMS).copied().collect()),
        _ => None,
    }
}

/// `*` matches any run of characters (also none).
fn glob_match(pattern: &str, text: &str) -> bool {
    match pattern.split_once('*') {
        None => pattern == text,
        Some((head, rest)) => {
            let Some(tail) = text.strip_prefix(head) else { return false };
            if rest.is_empty() {
                return true;
            }
            (0..=tail.len()).filter(|&i| tail.is_char_boundary(i)).any(|i| glob_match(rest, &tail[i..]))
        }
    }
}

/// Every channel of the skeleton (`root.tx`, …, `bone.dof`), in file order.
pub fn all_channels(skeleton: &Skeleton) -> Vec<String> {
    let mut out: Vec<String> = skeleton.root.order.iter().map(|d| format!("root.{}", d.as_str())).collect();
    for b in &skeleton.bones {
        out.extend(b.dofs.iter().map(|d| format!("{}.{}", b.name, d.as_str())));
    }
    out
}

/// Expands names, globs and groups into channel names of `skeleton`, in the given order.
/// The error says which entry matched nothing, or which channel came twice.
pub fn expand(entries: &[String], skeleton: &Skeleton) -> Result<Vec<String>, String> {
    expand_in(entries, &all_channels(skeleton))
}

/// [`expand`] against a list of available channel names (a motion without a skeleton).
pub fn expand_in(entries: &[String], all: &[String]) -> Result<Vec<String>, String> {
    let mut out: Vec<String> = Vec::new();
    for (k, e) in entries.iter().enumerate() {
        let found: Vec<String> = if let Some(g) = group(e) {
            g.into_iter().map(String::from).collect()
        } else if e.contains('*') {
            all.iter().filter(|c| glob_match(e, c)).cloned().collect()
        } else {
            vec![e.clone()]
        };
        if found.is_empty() {
            return Err(format!("channels[{k}] = \"{e}\" matches no channel of the motion"));
        }
        for c in found {
            if !all.contains(&c) {
                return Err(format!(
                    "channels[{k}]: '{c}' is not a channel of the motion{} (a channel is bone.dof, e.g. lfemur.rx; groups: legs, arms, hoap2)",
                    cpg_io::did_you_mean(&c, all.iter().map(String::as_str))
                ));
            }
            if out.contains(&c) {
                return Err(format!("channels[{k}]: '{c}' is named twice"));
            }
            out.push(c);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs() {
        assert!(glob_match("lfemur.*", "lfemur.rx"));
        assert!(glob_match("*.rx", "ltibia.rx"));
        assert!(!glob_match("lfemur.*", "rfemur.rx"));
        assert!(glob_match("*", "anything"));
        assert!(glob_match("l*.r*", "lfoot.rz"));
        assert!(!glob_match("l*.rx", "lfoot.rz"));
    }

    #[test]
    fn groups_are_the_map_channels() {
        assert_eq!(group("hoap2").unwrap().len(), 22);
        assert_eq!(group("legs").unwrap()[2], "lfemur.rx");
        assert!(group("lfemur.rx").is_none());
    }
}
