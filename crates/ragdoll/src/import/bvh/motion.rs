//! The motion section: `Frames:`, `Frame Time:` and one line per frame, each converted to
//! joint poses as it is read.

use std::path::Path;

use super::FRAME_TIME_RANGE_S;
use super::parse::{Convert, Lines, PJoint, check_range, parse_error, parse_number};
use crate::error::Result;
use crate::math::Transform;
use crate::skeleton::MAX_CLIP_POSES;

/// Case-insensitive ASCII prefix strip that cannot split a UTF-8 character.
fn strip_prefix_ci<'s>(s: &'s str, prefix: &str) -> Option<&'s str> {
    let head = s.get(..prefix.len())?;
    head.eq_ignore_ascii_case(prefix)
        .then(|| s.get(prefix.len()..))
        .flatten()
}

/// The value after `key` on a header line such as `Frames: 12` or `Frame Time:\t0.01`.
fn header_value<'s>(line: &'s str, key: &[&str]) -> Option<&'s str> {
    let mut rest = line.trim();
    for (i, word) in key.iter().enumerate() {
        if i > 0 {
            rest = rest.trim_start();
        }
        rest = strip_prefix_ci(rest, word)?;
    }
    let rest = rest.trim_start();
    let rest = rest.strip_prefix(':').unwrap_or(rest);
    Some(rest.trim())
}

/// The motion section, converted.
pub(super) struct Motion {
    /// The `Frames:` count.
    pub(super) count: usize,
    pub(super) frame_time: f64,
    /// Every frame's local joint transforms; `None` when the hierarchy has no channels
    /// (every frame is the rest pose, made once the skeleton exists).
    pub(super) frames: Option<Vec<Vec<Transform>>>,
    /// 1-based line of each frame.
    pub(super) frame_lines: Vec<usize>,
}

/// Reads `Frames:`, `Frame Time:` and the frame lines after the `MOTION` line, converting
/// each frame as it is read. Nothing is reserved from the announced count: a frame takes
/// memory only once its line has been read.
pub(super) fn read_motion(
    path: &Path,
    lines: &mut Lines,
    motion_line: usize,
    joints: &[PJoint],
    convert: &Convert,
) -> Result<Motion> {
    let channels: usize = joints.iter().map(|j| j.channels.len()).sum();
    let mut rest = lines.filter(|(_, l)| !l.trim().is_empty());
    let Some((frames_line, line)) = rest.next() else {
        return Err(parse_error(
            path,
            motion_line,
            "the file ends after MOTION; expected \"Frames: <count>\"",
        ));
    };
    let count: usize = header_value(line, &["Frames"])
        .ok_or_else(|| {
            parse_error(
                path,
                frames_line,
                format!("expected \"Frames: <count>\", found \"{}\"", line.trim()),
            )
        })?
        .parse()
        .map_err(|_| {
            parse_error(
                path,
                frames_line,
                format!("the frame count is not a whole number: \"{}\"", line.trim()),
            )
        })?;
    // The clip holds frames × joints transforms; refuse sizes that would exhaust memory
    // (a crash, not an error) rather than trust the count or a pathological hierarchy.
    if count.saturating_mul(joints.len()) > MAX_CLIP_POSES {
        return Err(parse_error(
            path,
            frames_line,
            format!(
                "{count} frames of {} joints exceed the {MAX_CLIP_POSES} joint poses this importer holds in memory",
                joints.len()
            ),
        ));
    }

    let Some((time_line, line)) = rest.next() else {
        return Err(parse_error(
            path,
            frames_line,
            "the file ends before \"Frame Time: <seconds>\"",
        ));
    };
    let frame_time = header_value(line, &["Frame", "Time"]).ok_or_else(|| {
        parse_error(
            path,
            time_line,
            format!(
                "expected \"Frame Time: <seconds>\", found \"{}\"",
                line.trim()
            ),
        )
    })?;
    let frame_time = parse_number(frame_time)
        .filter(|t| *t > 0.0)
        .ok_or_else(|| {
            parse_error(
                path,
                time_line,
                format!(
                    "the frame time is not a positive number: \"{}\"",
                    line.trim()
                ),
            )
        })?;
    let [lo, hi] = FRAME_TIME_RANGE_S;
    if !(lo..=hi).contains(&frame_time) {
        return Err(parse_error(
            path,
            time_line,
            format!(
                "the frame time {frame_time} s is outside the {lo} to {hi} s this importer accepts"
            ),
        ));
    }
    let mut last_line = time_line;

    let mut frames = Vec::new();
    let mut frame_lines = Vec::new();
    let mut row = Vec::with_capacity(channels);
    for (line_no, line) in rest {
        let f = frame_lines.len();
        if f >= count {
            return Err(parse_error(
                path,
                line_no,
                format!(
                    "more frame lines than the {count} that \"Frames:\" (line {frames_line}) announces"
                ),
            ));
        }
        let n = line.split_whitespace().count();
        if n != channels {
            return Err(parse_error(
                path,
                line_no,
                format!(
                    "frame {} has {n} values, but the hierarchy has {channels} channels",
                    f + 1
                ),
            ));
        }
        row.clear();
        for (k, word) in line.split_whitespace().enumerate() {
            let what = || format!("value {} of frame {}", k + 1, f + 1);
            let v = parse_number(word)
                .ok_or_else(|| {
                    parse_error(
                        path,
                        line_no,
                        format!("{} is not a finite number: \"{word}\"", what()),
                    )
                })
                .and_then(|v| check_range(v, &what()).map_err(|m| parse_error(path, line_no, m)))?;
            row.push(v);
        }
        frames.push(convert.frame(joints, &row));
        frame_lines.push(line_no);
        last_line = line_no;
    }
    if frame_lines.len() < count && channels > 0 {
        return Err(parse_error(
            path,
            last_line + 1,
            format!(
                "the motion data ends after {} frames, but \"Frames:\" (line {frames_line}) announces {count}",
                frame_lines.len()
            ),
        ));
    }
    Ok(Motion {
        count,
        frame_time,
        frames: (channels > 0).then_some(frames),
        frame_lines,
    })
}
