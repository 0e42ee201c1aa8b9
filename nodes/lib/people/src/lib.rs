//! Synthetic people (thesis Sec. 4.2): 11-segment skeletons and their motions.
