"""ament_python set-up of splines445_ros."""

from glob import glob

from setuptools import find_packages, setup

package_name = 'splines445_ros'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='splines445 developers',
    maintainer_email='splines445-dev@example.com',
    description='Jerk-continuous 445 spline trajectories through waypoints for ROS 2.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'planner_node = splines445_ros.nodes.planner_node:main',
            'arm_sim_node = splines445_ros.nodes.arm_sim_node:main',
            'demo = splines445_ros.tools.demo:main',
            'plot_trajectory = splines445_ros.tools.plot_trajectory:main',
        ],
    },
)
