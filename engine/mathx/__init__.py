"""mathx"""
