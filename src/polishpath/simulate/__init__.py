"""polishpath.simulate"""
