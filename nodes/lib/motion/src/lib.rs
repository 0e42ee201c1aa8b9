//! Motion representation: DMP, GMM/GMR, C-GMR, DHB invariants, DTW, HMM (thesis Ch. 3).
