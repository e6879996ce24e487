"""studies/common"""
