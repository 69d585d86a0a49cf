//! What a glTF input asks of its loader that this importer cannot give: refused at import,
//! in one sentence naming the file and the place.
//!
//! The exporter writes a glTF input back as it came, so a file we could not read as its
//! author meant (a required extension we cannot honour, another major glTF version) would
//! come out as a file that says one thing and holds another.

mod extensions;

pub use extensions::ACCEPTED_REQUIRED_EXTENSIONS;
pub(crate) use extensions::refuse_unreadable;
