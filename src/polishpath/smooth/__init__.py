"""polishpath.smooth"""
