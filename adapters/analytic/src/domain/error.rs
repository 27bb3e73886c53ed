//! The error type of the domain reader.

/// Why a domain file could not be read.
///
/// Every variant carries the file name (the `source_name` given to
/// [`crate::parse_domain`], or the path given to [`crate::read_domain`]) and
/// its `Display` starts with it, so a message can be shown to a user as is:
///
/// ```text
/// plate.toml: face 'plate' (face #1), hole 2: radius must be positive (got 0)
/// ```
#[derive(Debug, thiserror::Error)]
pub enum DomainError {
    /// The file could not be read (missing, unreadable, not UTF-8).
    #[error("{file}: cannot read the file: {source}")]
    Io {
        /// The file.
        file: String,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// The text is not TOML; `message` is the TOML parser's message, which
    /// gives the line and column.
    #[error("{file}: not valid TOML: {message}")]
    Toml {
        /// The file.
        file: String,
        /// The TOML parser's message.
        message: String,
    },
    /// The `format` key is missing, not a string, or names another format or
    /// version.
    #[error("{file}: {reason}")]
    Format {
        /// The file.
        file: String,
        /// What is wrong with the `format` key.
        reason: String,
    },
    /// The TOML does not follow the schema (unknown key, missing key, wrong
    /// type); `message` is the TOML deserialiser's message with line and
    /// column.
    #[error("{file}: not a valid bubblemesh domain: {message}")]
    Schema {
        /// The file.
        file: String,
        /// The deserialiser's message.
        message: String,
    },
    /// The description is well-formed but geometrically invalid; `entity`
    /// names the offending part, e.g. `face 'plate' (face #1), hole 2`
    /// (empty when the problem concerns the whole file).
    #[error("{file}: {}{reason}", entity_prefix(.entity))]
    Invalid {
        /// The file.
        file: String,
        /// The offending part (empty: the whole file).
        entity: String,
        /// Why it is invalid.
        reason: String,
    },
}

fn entity_prefix(entity: &str) -> String {
    if entity.is_empty() {
        String::new()
    } else {
        format!("{entity}: ")
    }
}

impl DomainError {
    /// The file (source name) the error is about.
    pub fn file(&self) -> &str {
        match self {
            DomainError::Io { file, .. }
            | DomainError::Toml { file, .. }
            | DomainError::Format { file, .. }
            | DomainError::Schema { file, .. }
            | DomainError::Invalid { file, .. } => file,
        }
    }
}

/// An invalid-geometry error before the file name is attached.
#[derive(Debug)]
pub(crate) struct Invalid {
    pub entity: String,
    pub reason: String,
}

impl Invalid {
    pub fn new(entity: impl Into<String>, reason: impl Into<String>) -> Self {
        Invalid {
            entity: entity.into(),
            reason: reason.into(),
        }
    }

    pub fn with_file(self, file: &str) -> DomainError {
        DomainError::Invalid {
            file: file.to_string(),
            entity: self.entity,
            reason: self.reason,
        }
    }
}
