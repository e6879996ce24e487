"""simulation/model"""
