//! Mesh writers and readers (being written).
