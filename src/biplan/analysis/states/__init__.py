"""The stable-state landscape: seeds and searches, the catalogue and its labels, hierarchy,
transitions between states, their barriers and departure loads (main "State space")."""
