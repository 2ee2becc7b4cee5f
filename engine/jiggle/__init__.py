"""jiggle"""
