"""Pictures: ``rpm-cl view`` (:mod:`.view`) and the README's figures
(:mod:`.figures`)."""
