"""Playback of a motion in meshcat."""
