"""polishpath.plan"""
