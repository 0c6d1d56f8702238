"""polishpath.psd"""
