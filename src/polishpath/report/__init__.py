"""polishpath.report"""
