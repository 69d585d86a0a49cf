//! Python exceptions for the library's errors: one class per kind of cause, carrying the
//! file, line, place, key and joint as attributes, so a script branches on the class and
//! reads the attributes instead of parsing the message.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    ragdoll_sim,
    RagdollError,
    PyException,
    "Base class of every error the engine raises. Attributes (None where they do not apply): \
     message (the sentence), file, line (1-based), place (a byte offset, an accessor, a \
     body or joint of a spec), key (the setting or key involved) and joint."
);
create_exception!(
    ragdoll_sim,
    FileFormatError,
    RagdollError,
    "A file that is malformed (BVH, OBJ, TOML, glTF) or of a type that is not read; \
     file, and line or place, say where."
);
create_exception!(
    ragdoll_sim,
    FileAccessError,
    RagdollError,
    "A file that could not be read or written, or that is refused before it is parsed \
     (not a regular file, too large)."
);
create_exception!(
    ragdoll_sim,
    BoundError,
    RagdollError,
    "A setting or argument outside what the engine accepts; key names it."
);
create_exception!(
    ragdoll_sim,
    SkeletonError,
    RagdollError,
    "A skeleton that breaks an invariant (a parent after its child, a rest pose out of \
     reach); joint names the joint."
);
create_exception!(
    ragdoll_sim,
    SpecError,
    RagdollError,
    "A ragdoll spec holding a value that cannot be simulated; place names the body, joint \
     or key."
);
create_exception!(
    ragdoll_sim,
    RoleError,
    RagdollError,
    "Roles given by hand that cannot be applied to the skeleton (a joint that is not there, \
     a shin that does not hang from its thigh); key names the role."
);
create_exception!(
    ragdoll_sim,
    Cancelled,
    RagdollError,
    "A run stopped by its progress callback returning False."
);
create_exception!(
    ragdoll_sim,
    InternalError,
    RagdollError,
    "A defect of the engine itself (a Rust panic), caught before it could end the Python \
     process; please report it with the input that caused it."
);

/// The attributes every [`RagdollError`] carries.
#[derive(Default)]
pub(crate) struct Fields {
    pub message: String,
    pub file: Option<String>,
    pub line: Option<usize>,
    pub place: Option<String>,
    pub key: Option<String>,
    pub joint: Option<String>,
}

/// Raises `T` with `fields` as its attributes; its text is the library's one sentence.
pub(crate) fn raise<T: pyo3::PyTypeInfo>(text: String, fields: Fields) -> PyErr {
    let err = PyErr::new::<T, _>(text);
    Python::attach(|py| {
        let value = err.value(py);
        // Setting attributes on a fresh exception instance cannot fail in practice; were it
        // to, the exception is still raised with its message.
        let _ = value.setattr("message", fields.message);
        let _ = value.setattr("file", fields.file);
        let _ = value.setattr("line", fields.line);
        let _ = value.setattr("place", fields.place);
        let _ = value.setattr("key", fields.key);
        let _ = value.setattr("joint", fields.joint);
    });
    err
}

/// The kind of exception a library error becomes.
enum Kind {
    Access,
    Format,
    Skeleton,
    Spec,
    Bound,
}

/// The exception for a library error: its class from the variant, its attributes from the
/// variant's data.
pub(crate) fn to_py(e: ragdoll::Error) -> PyErr {
    use ragdoll::Error as E;
    let text = e.to_string();
    let at = |path: &Path, message: String| Fields {
        message,
        file: Some(path.display().to_string()),
        ..Fields::default()
    };
    let (kind, fields) = match e {
        E::Io { path, error } => (Kind::Access, at(&path, error.to_string())),
        E::Refused { path, message } => (Kind::Access, at(&path, message)),
        E::Parse {
            path,
            line,
            message,
        } => (
            Kind::Format,
            Fields {
                line: Some(line),
                ..at(&path, message)
            },
        ),
        E::Format {
            path,
            place,
            message,
        } => (
            Kind::Format,
            Fields {
                place: Some(place),
                ..at(&path, message)
            },
        ),
        E::NoSuchClip {
            path,
            asked,
            message,
        } => (
            Kind::Format,
            Fields {
                place: Some(asked),
                ..at(&path, message)
            },
        ),
        E::UnsupportedFile { ref path } => (Kind::Format, at(path, text.clone())),
        E::Skeleton { joint, message } => (
            Kind::Skeleton,
            Fields {
                message,
                joint: Some(joint),
                ..Fields::default()
            },
        ),
        E::Spec { place, message } => (
            Kind::Spec,
            Fields {
                message,
                place: Some(place),
                ..Fields::default()
            },
        ),
        E::Setting { setting, message } => (
            Kind::Bound,
            Fields {
                message,
                key: Some(setting),
                ..Fields::default()
            },
        ),
    };
    match kind {
        Kind::Access => raise::<FileAccessError>(text, fields),
        Kind::Format => raise::<FileFormatError>(text, fields),
        Kind::Skeleton => raise::<SkeletonError>(text, fields),
        Kind::Spec => raise::<SpecError>(text, fields),
        Kind::Bound => raise::<BoundError>(text, fields),
    }
}

/// A [`BoundError`] about the argument `key`.
pub(crate) fn bound(key: &str, message: impl Into<String>) -> PyErr {
    let message = message.into();
    raise::<BoundError>(
        format!("{key}: {message}"),
        Fields {
            message,
            key: Some(key.into()),
            ..Fields::default()
        },
    )
}

/// Runs `f`, turning a Rust panic into one [`InternalError`] instead of letting it unwind
/// into Python (PyO3 would raise its `PanicException`, a `BaseException` that ordinary
/// `except Exception` handlers miss).
pub(crate) fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            let message = format!("internal error in the ragdoll engine: {what}");
            Err(raise::<InternalError>(
                message.clone(),
                Fields {
                    message,
                    ..Fields::default()
                },
            ))
        }
    }
}

/// Registers the exception classes on the module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("RagdollError", py.get_type::<RagdollError>())?;
    m.add("FileFormatError", py.get_type::<FileFormatError>())?;
    m.add("FileAccessError", py.get_type::<FileAccessError>())?;
    m.add("BoundError", py.get_type::<BoundError>())?;
    m.add("SkeletonError", py.get_type::<SkeletonError>())?;
    m.add("SpecError", py.get_type::<SpecError>())?;
    m.add("RoleError", py.get_type::<RoleError>())?;
    m.add("Cancelled", py.get_type::<Cancelled>())?;
    m.add("InternalError", py.get_type::<InternalError>())?;
    Ok(())
}
