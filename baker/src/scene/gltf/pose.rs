//! Which pose a glTF file is read in (`--pose`): its nodes' own transforms, or an animation
//! sampled at a time or at one of its keyframes ([`super::skin`] applies it).

use std::fmt;
use std::str::FromStr;

/// `--pose rest | ANIM@SECONDS | ANIM#KEYFRAME`. ANIM is an animation's name, or its index
/// in the file when no animation has that name.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Pose {
    /// The nodes' own transforms, no animation applied: what a viewer shows before playing.
    #[default]
    Rest,
    /// The animation at a time in seconds (clamped to its keyframes' range, as players hold
    /// the first and last keyframes).
    Time { animation: String, seconds: f32 },
    /// The animation at the time of its keyframe K: the K-th smallest of every keyframe time
    /// of its channels.
    Keyframe { animation: String, index: usize },
}

impl Pose {
    pub fn is_rest(&self) -> bool {
        *self == Pose::Rest
    }
}

impl FromStr for Pose {
    type Err = String;

    fn from_str(text: &str) -> Result<Pose, String> {
        let usage =
            "a pose is rest, ANIM@SECONDS or ANIM#KEYFRAME (ANIM an animation's name or index)";
        if text == "rest" {
            return Ok(Pose::Rest);
        }
        if let Some((animation, seconds)) = text.rsplit_once('@') {
            let seconds: f32 = seconds
                .parse()
                .ok()
                .filter(|s: &f32| s.is_finite())
                .ok_or_else(|| {
                    format!("'{text}': '{seconds}' is not a time in seconds; {usage}")
                })?;
            if !animation.is_empty() {
                let animation = animation.to_owned();
                return Ok(Pose::Time { animation, seconds });
            }
        }
        if let Some((animation, index)) = text.rsplit_once('#') {
            let index: usize = index
                .parse()
                .map_err(|_| format!("'{text}': '{index}' is not a keyframe number; {usage}"))?;
            if !animation.is_empty() {
                let animation = animation.to_owned();
                return Ok(Pose::Keyframe { animation, index });
            }
        }
        Err(format!("'{text}': {usage}"))
    }
}

impl fmt::Display for Pose {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Pose::Rest => write!(f, "rest"),
            Pose::Time { animation, seconds } => write!(f, "{animation}@{seconds}"),
            Pose::Keyframe { animation, index } => write!(f, "{animation}#{index}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poses_parse_and_print_back() {
        for text in ["rest", "bend@0.5", "walk cycle#3", "0@1"] {
            assert_eq!(text.parse::<Pose>().unwrap().to_string(), text);
        }
        for bad in ["", "bend", "@1", "bend@x", "bend#-1", "bend@inf"] {
            assert!(bad.parse::<Pose>().is_err(), "{bad}");
        }
    }
}
