"""estimators/ukf"""
