"""anim"""
