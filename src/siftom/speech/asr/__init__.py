"""Speech recognisers behind one interface (``base.ASREngine``); engines load lazily."""
