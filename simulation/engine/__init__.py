"""simulation/engine"""
