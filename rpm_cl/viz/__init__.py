"""Pictures: ``rpm-cl view`` (:mod:`.view`) and the paper-style figures
(:mod:`.figures`)."""
