//! The checks every message from a page passes: what is accepted and what is refused.

use ragdoll_view::protocol::{
    BackendChoice, ClientMsg, MAX_MESSAGE_BYTES, SceneShape, parse_client_message,
};

fn shape() -> SceneShape {
    SceneShape {
        bodies: vec![15, 3],
        joints: vec![14, 2],
    }
}

fn ok(text: &str) -> ClientMsg {
    parse_client_message(text, &shape()).unwrap_or_else(|e| panic!("{text}: {e}"))
}

fn refused(text: &str) -> String {
    match parse_client_message(text, &shape()) {
        Ok(m) => panic!("accepted {text} as {m:?}"),
        Err(e) => e.0,
    }
}

#[test]
fn every_kind_of_valid_message_is_accepted() {
    assert_eq!(ok(r#"{"type":"play"}"#), ClientMsg::Play {});
    assert_eq!(ok(r#"{"type":"pause"}"#), ClientMsg::Pause {});
    assert_eq!(ok(r#"{"type":"step"}"#), ClientMsg::Step {});
    assert_eq!(ok(r#"{"type":"reset"}"#), ClientMsg::Reset {});
    assert_eq!(ok(r#"{"type":"drag_end"}"#), ClientMsg::DragEnd {});
    assert_eq!(
        ok(r#"{"type":"save"}"#),
        ClientMsg::Save { overwrite: false }
    );
    assert_eq!(
        ok(r#"{"type":"save","overwrite":true}"#),
        ClientMsg::Save { overwrite: true }
    );
    assert_eq!(
        ok(r#"{"type":"scrub","time_s":1.5}"#),
        ClientMsg::Scrub { time_s: 1.5 }
    );
    assert_eq!(
        ok(r#"{"type":"backend","kind":"particle"}"#),
        ClientMsg::Backend {
            kind: BackendChoice::Particle
        }
    );
    assert_eq!(
        ok(r#"{"type":"drag_start","ragdoll":1,"body":2,"local":[0,0.1,0],"target":[1,2,3]}"#),
        ClientMsg::DragStart {
            ragdoll: 1,
            body: 2,
            local: [0.0, 0.1, 0.0],
            target: [1.0, 2.0, 3.0]
        }
    );
    ok(r#"{"type":"drag_move","target":[-1,0.5,2]}"#);
    ok(r#"{"type":"blast","position":[1,0.5,0],"tnt_kg":10,"delay_s":0.5}"#);
    ok(
        r#"{"type":"edit_body","ragdoll":0,"body":14,"radius_m":0.05,"length_m":0.3,"center_m":[0,0.1,0],"mass_kg":4}"#,
    );
    ok(r#"{"type":"edit_joint","ragdoll":0,"joint":13,"min_deg":0,"max_deg":140}"#);
    ok(r#"{"type":"edit_joint","ragdoll":1,"joint":1,"swing_deg":45,"twist_deg":[-20,20]}"#);
}

#[test]
fn malformed_json_and_wrong_types_are_refused() {
    for text in [
        "",
        "not json",
        "{",
        "[]",
        "null",
        r#"{"type":"play"} trailing"#,
        r#"{"kind":"play"}"#,
        r#"{"type":"launch"}"#,
        r#"{"type":"scrub","time_s":"soon"}"#,
        r#"{"type":"scrub"}"#,
        r#"{"type":"drag_move","target":[1,2]}"#,
        r#"{"type":"drag_move","target":[1,2,3,4]}"#,
        r#"{"type":"drag_start","ragdoll":-1,"body":0,"local":[0,0,0],"target":[0,0,0]}"#,
        r#"{"type":"backend","kind":"soft"}"#,
        r#"{"type":"save","overwrite":"yes"}"#,
        r#"{"type":"save","overwrite":1}"#,
    ] {
        refused(text);
    }
}

#[test]
fn unknown_fields_are_refused() {
    refused(r#"{"type":"pause","now":true}"#);
    refused(r#"{"type":"blast","position":[1,0,0],"tnt_kg":5,"delay_s":0,"scale":100}"#);
    let why = refused(r#"{"type":"drag_move","target":[0,1,0],"force":1e9}"#);
    assert!(why.contains("force"), "{why}");
}

#[test]
fn numbers_that_are_not_finite_or_out_of_range_are_refused() {
    // JSON has no NaN or infinity; these are how they arrive: not JSON at all, or a number
    // too large for f32 (parsed as infinity).
    refused(r#"{"type":"drag_move","target":[NaN,0,0]}"#);
    refused(r#"{"type":"drag_move","target":[Infinity,0,0]}"#);
    refused(r#"{"type":"drag_move","target":[1e39,0,0]}"#);
    refused(r#"{"type":"drag_move","target":[0,-5000,0]}"#);
    refused(r#"{"type":"scrub","time_s":-1}"#);
    refused(r#"{"type":"scrub","time_s":1e300}"#);
    refused(r#"{"type":"blast","position":[0,0,0],"tnt_kg":0,"delay_s":0}"#);
    refused(r#"{"type":"blast","position":[0,0,0],"tnt_kg":-5,"delay_s":0}"#);
    refused(r#"{"type":"blast","position":[0,0,0],"tnt_kg":1e6,"delay_s":0}"#);
    refused(r#"{"type":"blast","position":[0,0,0],"tnt_kg":5,"delay_s":-1}"#);
    refused(
        r#"{"type":"edit_body","ragdoll":0,"body":0,"radius_m":0,"length_m":0.3,"center_m":[0,0,0],"mass_kg":4}"#,
    );
    refused(
        r#"{"type":"edit_body","ragdoll":0,"body":0,"radius_m":0.1,"length_m":-0.3,"center_m":[0,0,0],"mass_kg":4}"#,
    );
    refused(
        r#"{"type":"edit_body","ragdoll":0,"body":0,"radius_m":0.1,"length_m":0.3,"center_m":[0,2000,0],"mass_kg":4}"#,
    );
    refused(
        r#"{"type":"edit_body","ragdoll":0,"body":0,"radius_m":0.1,"length_m":0.3,"center_m":[0,0,0],"mass_kg":0}"#,
    );
    refused(r#"{"type":"edit_joint","ragdoll":0,"joint":0,"min_deg":10,"max_deg":-10}"#);
    refused(r#"{"type":"edit_joint","ragdoll":0,"joint":0,"min_deg":-200,"max_deg":10}"#);
    refused(r#"{"type":"edit_joint","ragdoll":0,"joint":0,"swing_deg":200,"twist_deg":[0,1]}"#);
}

#[test]
fn indices_past_the_scene_are_refused() {
    let why =
        refused(r#"{"type":"drag_start","ragdoll":0,"body":15,"local":[0,0,0],"target":[0,1,0]}"#);
    assert!(why.contains("no body 15"), "{why}");
    refused(r#"{"type":"drag_start","ragdoll":1,"body":3,"local":[0,0,0],"target":[0,1,0]}"#);
    refused(r#"{"type":"drag_start","ragdoll":2,"body":0,"local":[0,0,0],"target":[0,1,0]}"#);
    refused(
        r#"{"type":"edit_body","ragdoll":5,"body":0,"radius_m":0.1,"length_m":0.3,"center_m":[0,0,0],"mass_kg":4}"#,
    );
    refused(r#"{"type":"edit_joint","ragdoll":0,"joint":14,"min_deg":0,"max_deg":10}"#);
    refused(r#"{"type":"edit_joint","ragdoll":1,"joint":2,"min_deg":0,"max_deg":10}"#);
}

#[test]
fn joint_edits_must_be_of_one_kind_and_complete() {
    refused(r#"{"type":"edit_joint","ragdoll":0,"joint":0}"#);
    refused(r#"{"type":"edit_joint","ragdoll":0,"joint":0,"min_deg":0}"#);
    refused(r#"{"type":"edit_joint","ragdoll":0,"joint":0,"swing_deg":30}"#);
    refused(
        r#"{"type":"edit_joint","ragdoll":0,"joint":0,"min_deg":0,"max_deg":10,"swing_deg":30,"twist_deg":[0,1]}"#,
    );
}

#[test]
fn huge_messages_are_refused_before_parsing() {
    let pad = "x".repeat(MAX_MESSAGE_BYTES);
    let why = refused(&format!(r#"{{"type":"pause","pad":"{pad}"}}"#));
    assert!(why.contains("limit"), "{why}");
    // Whitespace counts too: size is checked on the raw text.
    refused(&format!(
        r#"{{"type":"pause"{}}}"#,
        " ".repeat(MAX_MESSAGE_BYTES)
    ));
}
