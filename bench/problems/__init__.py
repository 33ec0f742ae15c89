"""Problems: the scenes (``scenes``), their reference solutions (``reference``) and which model a scene needs
(``adequacy``)."""
