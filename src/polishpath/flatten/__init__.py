"""polishpath.flatten"""
