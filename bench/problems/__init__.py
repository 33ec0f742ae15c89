"""Problems: the scenes (``scenes``), their reference solutions (``reference``) and the turning points and
precession rate measured on a trajectory (``turning_points``), which the reference and the verdicts share."""
