"""polishpath.surfaces"""
