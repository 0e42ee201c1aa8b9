//! Cross-node integration tests of the cowork graph.
