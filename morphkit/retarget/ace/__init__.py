"""ACE (Li et al. 2023): human → any-creature retargeting with a motion prior, an adversarial
correspondence embedding and the KL end-effector mapping. Torch only; creature-agnostic."""
