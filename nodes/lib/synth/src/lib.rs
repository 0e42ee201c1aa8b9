//! Deterministic scenario bags (thesis Sec. 5.1.3, 4.2): depth, tf, skeletons, wrench, speech.
