//! The name-hints pass: what a joint's name says it is (a thigh, a left hand, an IK pole),
//! across the naming styles rigs come in. Names are hints: the structure and geometry
//! passes confirm or overrule them.

/// +1 when a joint name says left, −1 for right, 0 otherwise.
pub(crate) fn side_hint(name: &str) -> i32 {
    let delimited = delimited_side(name);
    if delimited != 0 {
        return delimited;
    }
    for t in tokens(name) {
        match t.as_str() {
            "l" | "left" | "lft" => return 1,
            "r" | "right" | "rt" | "rgt" => return -1,
            _ if t.starts_with("left") => return 1,
            _ if t.starts_with("right") => return -1,
            _ => {}
        }
    }
    0
}

/// The side a name sets apart with separators, which wins over a side inside a word: the
/// suffix first (Blender's `.L`, `_R`; numbered copies such as `upper_arm.L.001` keep it
/// before their number), then the prefix (`L_`, `Left-`). A mech's `PalmR.L` is a left
/// palm whose own name ends in R. 0 when neither end is a side word.
fn delimited_side(name: &str) -> i32 {
    let mut pieces: Vec<String> = name
        .split(|c: char| !c.is_alphanumeric())
        .filter(|p| !p.is_empty())
        .map(str::to_lowercase)
        .collect();
    while pieces.len() > 1
        && pieces
            .last()
            .is_some_and(|p| p.chars().all(|c| c.is_ascii_digit()))
    {
        pieces.pop();
    }
    if pieces.len() < 2 {
        return 0;
    }
    [pieces.last(), pieces.first()]
        .into_iter()
        .flatten()
        .map(|p| match p.as_str() {
            "l" | "left" | "lft" => 1,
            "r" | "right" | "rt" | "rgt" => -1,
            _ => 0,
        })
        .find(|&s| s != 0)
        .unwrap_or(0)
}

/// What a joint's name says it is, in the ragdoll's anatomy. Coarser than
/// [`Role`](crate::spec::Role): a collar, a toe or a finger is named but gets no body.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Part {
    Pelvis,
    Spine,
    Chest,
    Neck,
    Head,
    Clavicle,
    UpperArm,
    Forearm,
    Hand,
    Thigh,
    Shin,
    Foot,
    Toe,
    Finger,
}

/// The name-hints pass's verdict on one joint.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct NameHint {
    /// The body part the name says, if any; none for a helper.
    pub part: Option<Part>,
    /// +1 left, −1 right, 0 unsided.
    pub side: i32,
    /// A bone that is not anatomy (IK target or pole, control, twist or roll bone, weapon
    /// socket, eye, end marker): it never gets a body.
    pub helper: bool,
    /// The name's words without side, prefixes and numbers (`mixamorig:LeftUpLeg` →
    /// `upleg`): two bones with the same stem split one segment (Rigify's `.001`).
    pub stem: String,
}

/// Words that make a bone a helper wherever they appear in its name (lower case, joined).
const HELPER_PARTS: [&str; 14] = [
    "control", "ctrl", "pole", "target", "orient", "master", "twist", "roll", "slot", "socket",
    "tracker", "weapon", "attach", "helper",
];
/// Whole words that make a bone a helper (too short to search for inside other words).
const HELPER_WORDS: [&str; 8] = ["ik", "mch", "org", "wgt", "end", "nub", "prop", "eye"];
/// Words that carry nothing about the part: exporter prefixes and joiners.
const NOISE_WORDS: [&str; 11] = [
    "def",
    "c",
    "b",
    "bip",
    "bone",
    "bn",
    "jnt",
    "joint",
    "j",
    "mixamorig",
    "cc",
];
/// Finger words: a finger rides on its hand whatever else its name says.
const FINGER_WORDS: [&str; 10] = [
    "thumb",
    "index",
    "middle",
    "ring",
    "pinky",
    "little",
    "finger",
    "fingers",
    "digit",
    "metacarpal",
];

/// Words before or after a part's name that leave the part as it is: Daz Genesis splits a
/// limb into `lThighBend` and `lThighTwist` and its trunk into `abdomenLower`,
/// `chestUpper`, `neckLower`. Read only where the whole stem names nothing, so
/// `upperarm` stays an upper arm and `lowerleg` a shin.
const QUALIFIER_WORDS: [&str; 4] = ["bend", "upper", "lower", "mid"];

/// The part a stem names, or else the part it names without one qualifier word before or
/// after ([`QUALIFIER_WORDS`]).
fn part_of_qualified_stem(stem: &str, sided: bool) -> Option<Part> {
    part_of_stem(stem, sided).or_else(|| {
        QUALIFIER_WORDS.iter().find_map(|q| {
            let bare = stem.strip_suffix(q).or_else(|| stem.strip_prefix(q))?;
            part_of_stem(bare, sided)
        })
    })
}

/// The part `words` name: all of them, else all but the first few, which are then a
/// prefix the exporter put before every name (`CC_Base_L_Thigh`, `Character1_LeftUpLeg`,
/// `ValveBiped.Bip01_L_Calf`). The last word alone is tried last.
fn part_of_words(words: &[&str], sided: bool) -> Option<Part> {
    (0..words.len()).find_map(|k| part_of_qualified_stem(&words[k..].concat(), sided))
}

/// The part a stem names; `sided` tells `LeftHip` (a thigh) from `Hip` (the pelvis) and
/// CMU's `LeftShoulder` (an upper arm) from an unsided shoulder.
fn part_of_stem(stem: &str, sided: bool) -> Option<Part> {
    use Part::*;
    Some(match stem {
        "hips" | "pelvis" if !sided => Pelvis,
        "hip" if !sided => Pelvis,
        "spine" | "abdomen" | "lowerback" | "waist" | "belly" | "stomach" => Spine,
        "chest" | "upperchest" | "torso" | "thorax" | "ribcage" => Chest,
        "neck" | "lowerneck" | "upperneck" => Neck,
        "head" => Head,
        "collar" | "clavicle" | "collarbone" => Clavicle,
        "upperarm" | "uparm" | "armupper" | "arm" | "shldr" | "humerus" => UpperArm,
        "shoulder" if sided => UpperArm,
        "forearm" | "lowerarm" | "lowarm" | "armlower" | "elbow" => Forearm,
        "hand" | "wrist" | "fist" | "palm" => Hand,
        "thigh" | "upleg" | "upperleg" | "legupper" | "femur" => Thigh,
        "hip" if sided => Thigh,
        "shin" | "calf" | "leg" | "lowleg" | "lowerleg" | "leglower" | "knee" | "shank" => Shin,
        "foot" | "ankle" => Foot,
        "toe" | "toes" | "toebase" | "ball" => Toe,
        _ => return None,
    })
}

/// Reads one joint name: the part it names, its side, whether it is a helper. Handles
/// `prefix:` namespaces (Mixamo), `DEF-` (Rigify), side words or letters before or after
/// (`LeftArm`, `l-arm`, `upperarm_l`, `upperarm.l`, `Fist.L`) and CMU's glued `lhand`.
pub(crate) fn name_hint(name: &str) -> NameHint {
    let local = name.rsplit(':').next().unwrap_or(name);
    let joined: String = local
        .chars()
        .filter(|c| c.is_alphanumeric())
        .collect::<String>()
        .to_lowercase();
    let mut side = 0;
    let mut words: Vec<String> = Vec::new();
    for t in tokens(local) {
        let glued = |p: &str| {
            t.strip_prefix(p)
                .filter(|rest| part_of_stem(rest, true).is_some())
                .map(str::to_string)
        };
        let (s, word) = match t.as_str() {
            "l" | "left" | "lft" => (1, None),
            "r" | "right" | "rt" | "rgt" => (-1, None),
            _ if t.starts_with("left") => (1, Some(t["left".len()..].to_string())),
            _ if t.starts_with("right") => (-1, Some(t["right".len()..].to_string())),
            _ => match (glued("l"), glued("r")) {
                (Some(w), _) => (1, Some(w)),
                (_, Some(w)) => (-1, Some(w)),
                _ => (0, Some(t.clone())),
            },
        };
        if side == 0 {
            side = s;
        }
        words.extend(word.filter(|w| !w.is_empty()));
    }
    let delimited = delimited_side(local);
    if delimited != 0 {
        side = delimited;
    }
    let helper = HELPER_PARTS.iter().any(|h| joined.contains(h))
        || words.iter().any(|w| HELPER_WORDS.contains(&w.as_str()))
        || words.iter().any(|w| w.starts_with("eye"));
    let finger = words
        .iter()
        .any(|w| FINGER_WORDS.iter().any(|f| w.starts_with(f)));
    let kept: Vec<&str> = words
        .iter()
        .filter(|w| !NOISE_WORDS.contains(&w.as_str()))
        .filter(|w| !w.chars().all(|c| c.is_ascii_digit()))
        .map(String::as_str)
        .collect();
    let stem = kept.concat();
    // A helper names no part, whatever words it borrows (`ik_foot_l`).
    let part = if helper {
        None
    } else if finger {
        Some(Part::Finger)
    } else {
        part_of_words(&kept, side != 0)
    };
    NameHint {
        part,
        side,
        helper,
        stem,
    }
}

/// The name without its digits and separators, lower case: `DEF-upper_arm.L.001` and
/// `DEF-upper_arm.L` are one segment split in two.
pub(crate) fn without_numbers(name: &str) -> String {
    name.chars()
        .filter(|c| c.is_alphabetic())
        .collect::<String>()
        .to_lowercase()
}

pub(super) fn has_token(name: &str, word: &str) -> bool {
    tokens(name).iter().any(|t| t == word)
}

/// Splits a joint name into lower-case words: at non-alphanumerics, between lower and
/// upper case (`lThigh` → `l`, `thigh`), before the last capital of a capital run
/// (`LThigh` → `l`, `thigh`), and between letters and digits.
pub(super) fn tokens(name: &str) -> Vec<String> {
    let mut out = Vec::new();
    for piece in name.split(|c: char| !c.is_alphanumeric()) {
        let chars: Vec<char> = piece.chars().collect();
        let mut word = String::new();
        for (i, &c) in chars.iter().enumerate() {
            let prev = i.checked_sub(1).map(|p| chars[p]);
            let next = chars.get(i + 1);
            let boundary = match prev {
                None => false,
                Some(p) => {
                    (p.is_lowercase() && c.is_uppercase())
                        || (p.is_uppercase()
                            && c.is_uppercase()
                            && next.is_some_and(|n| n.is_lowercase()))
                        || (p.is_alphabetic() != c.is_alphabetic())
                }
            };
            if boundary && !word.is_empty() {
                out.push(std::mem::take(&mut word).to_lowercase());
            }
            word.push(c);
        }
        if !word.is_empty() {
            out.push(word.to_lowercase());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (name, part, side, helper) for one joint of each naming style.
    #[test]
    fn spec_roles_name_hints_across_styles() {
        use Part::*;
        let cases: &[(&str, Option<Part>, i32, bool)] = &[
            ("mixamorig:LeftUpLeg", Some(Thigh), 1, false),
            ("mixamorig7:RightForeArm", Some(Forearm), -1, false),
            ("mixamorig:LeftShoulder", Some(UpperArm), 1, false),
            ("mixamorig:Hips", Some(Pelvis), 0, false),
            ("upperarm_l", Some(UpperArm), 1, false),
            ("calf_r", Some(Shin), -1, false),
            ("upperarm.l", Some(UpperArm), 1, false),
            ("upperarm_twist_01_l", None, 1, true),
            ("ik_foot_l", None, 1, true),
            ("DEF-thigh.L", Some(Thigh), 1, false),
            ("DEF-upper_arm.L.001", Some(UpperArm), 1, false),
            ("MCH-thigh_parent.L", None, 1, true),
            ("Foot.R", Some(Foot), -1, false),
            ("Fist.L", Some(Hand), 1, false),
            ("PalmR.L", Some(Hand), 1, false),
            ("PalmR.R", Some(Hand), -1, false),
            ("L_PalmR", Some(Hand), 1, false),
            ("DEF-forearm.R.001", Some(Forearm), -1, false),
            ("PoleTarget.L", None, 1, true),
            ("l-thigh", Some(Thigh), 1, false),
            ("r-leg", Some(Shin), -1, false),
            ("l-LEGCONTROL", None, 1, true),
            ("MASTER", None, 0, true),
            ("headtracker", None, 0, true),
            ("LeftUpperLeg", Some(Thigh), 1, false),
            ("J_Bip_L_LowerArm", Some(Forearm), 1, false),
            ("J_Bip_C_Hips", Some(Pelvis), 0, false),
            ("upperleg.l", Some(Thigh), 1, false),
            ("wrist.l", Some(Hand), 1, false),
            ("handslot.l", None, 1, true),
            ("LHipJoint", Some(Thigh), 1, false),
            ("LeftHip", Some(Thigh), 1, false),
            ("lowerback", Some(Spine), 0, false),
            ("Chest2", Some(Chest), 0, false),
            ("lhand", Some(Hand), 1, false),
            ("rhand", Some(Hand), -1, false),
            ("LFingers", Some(Finger), 1, false),
            ("lShldr", Some(UpperArm), 1, false),
            ("lCollar", Some(Clavicle), 1, false),
            ("leftEye", None, 1, true),
            ("LeftInHandIndex", Some(Finger), 1, false),
            ("LeftToeBase", Some(Toe), 1, false),
            ("hip", Some(Pelvis), 0, false),
            ("Head", Some(Head), 0, false),
            ("rib", None, 0, false),
            ("b_LeftLeg01_015", Some(Shin), 1, false),
            ("lThighBend", Some(Thigh), 1, false),
            ("rShldrBend", Some(UpperArm), -1, false),
            ("lForearmTwist", None, 1, true),
            ("chestUpper", Some(Chest), 0, false),
            ("abdomenLower", Some(Spine), 0, false),
            ("neckLower", Some(Neck), 0, false),
            ("upperFaceRig", None, 0, false),
            ("CC_Base_L_Calf", Some(Shin), 1, false),
            ("CC_Base_Pelvis", Some(Pelvis), 0, false),
            ("CC_Base_L_KneeShareBone", None, 1, false),
            ("Character1_LeftUpLeg", Some(Thigh), 1, false),
            ("Character1_Hips", Some(Pelvis), 0, false),
            ("Leg_Upper_L", Some(Thigh), 1, false),
            ("Leg_Lower_L", Some(Shin), 1, false),
            ("Arm_Upper_R", Some(UpperArm), -1, false),
            ("Arm_Lower_R", Some(Forearm), -1, false),
            ("Bip01 L UpperArm", Some(UpperArm), 1, false),
            ("ValveBiped.Bip01_L_Forearm", Some(Forearm), 1, false),
        ];
        for &(name, part, side, helper) in cases {
            let h = name_hint(name);
            assert_eq!(
                (h.part, h.side, h.helper),
                (part, side, helper),
                "{name}: {h:?}"
            );
        }
    }

    #[test]
    fn spec_roles_tokens_and_side_hints() {
        assert_eq!(tokens("lThigh"), ["l", "thigh"]);
        assert_eq!(tokens("LThigh"), ["l", "thigh"]);
        assert_eq!(
            tokens("mixamorig:LeftUpLeg"),
            ["mixamorig", "left", "up", "leg"]
        );
        assert_eq!(tokens("b_LeftLeg01_015"), ["b", "left", "leg", "01", "015"]);
        assert_eq!(side_hint("lThigh"), 1);
        assert_eq!(side_hint("thigh_l"), 1);
        assert_eq!(side_hint("Bip01 R Thigh"), -1);
        assert_eq!(side_hint("RightHand"), -1);
        assert_eq!(side_hint("lowerarm"), 0);
        assert_eq!(side_hint("LowLeg"), 0);
        assert_eq!(side_hint("rib"), 0);
        assert_eq!(side_hint("Hips"), 0);
    }
}
