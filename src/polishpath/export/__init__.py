"""polishpath.export"""
